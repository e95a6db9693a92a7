"""lab: soft robot control with a learned differentiable model.

Pipeline: description -> mesh -> energy (fem) -> statics -> sampling/dataset -> ...
"""
__version__ = "0.1.0"
