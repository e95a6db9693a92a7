// A soft finger as a CAD program would give it (OpenCASCADE kernel, millimetres):
// a rounded bar 80 mm long, 18 mm wide, 16 mm thick, with a capped tip. The face at x = 0
// is the physical surface "base" that clamps it (finger.toml: clamp_group = "base").
SetFactory("OpenCASCADE");
Box(1) = {0, -9, -8, 72, 18, 16};
Cylinder(2) = {72, 0, 0, 8, 0, 0, 8};
BooleanUnion(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
base() = Surface In BoundingBox{-0.01, -10, -10, 0.01, 10, 10};
Physical Surface("base") = {base()};
Physical Volume("finger") = {3};
