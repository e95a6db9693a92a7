// A PneuNet bending finger (the layout of Mosadegh et al., "Pneumatic Networks for Soft
// Robotics that Actuate Rapidly", Adv. Funct. Mater. 24, 2014), OpenCASCADE, millimetres:
// a bar 90 x 16 x 15 mm whose upper part holds seven chambers, 6 mm long at an 11 mm pitch,
// joined by one channel along the bar. The chambers and channel are one cavity, the
// physical surface "cavity" (pneunet.toml: surface_group = "cavity"); the thick layer
// under them (4 mm) extends less, so the finger curls towards -z when they inflate.
// The face at x = 0 is the physical surface "base" that clamps it.
SetFactory("OpenCASCADE");
L = 90; W = 16; z0 = -5; z1 = 10;
Box(1) = {0, -W/2, z0, L, W, z1 - z0};
For i In {0:6}
  Box(10 + i) = {10 + 11 * i, -5.5, -1, 6, 11, 8};
EndFor
Box(20) = {10, -1.5, -1, 72, 3, 2};
BooleanUnion(30) = { Volume{10}; Delete; }{ Volume{11:16, 20}; Delete; };
BooleanDifference(40) = { Volume{1}; Delete; }{ Volume{30}; Delete; };
cavity() = Surface In BoundingBox{0.5, -W/2 + 0.5, z0 + 0.5, L - 0.5, W/2 - 0.5, z1 - 0.5};
base() = Surface In BoundingBox{-0.01, -W/2 - 0.1, z0 - 0.1, 0.01, W/2 + 0.1, z1 + 0.1};
Physical Surface("cavity") = {cavity()};
Physical Surface("base") = {base()};
Physical Volume("finger") = {40};
