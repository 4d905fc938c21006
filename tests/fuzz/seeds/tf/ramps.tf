# ramps and constants, labels, comments
-32768 -1000 constant 0 0 0 0 air
-1000  -300  ramp 0 0 0 0   1.0 0.79 0.6 0.12  fat
 -300    50  constant 1.0 0.79 0.6 0.12 skin   # the skin
  300  2000  ramp 1 1 1 0.2  1 1 1 0.9
 2000 32768  constant 1 0.9 0.2 1 filling
