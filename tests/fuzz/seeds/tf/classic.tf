# classic.tf: the classic CT transfer function of the coursework: translucent skin over bone.
#
# One range per line; '#' starts a comment, blank lines are ignored:
#   FROM  TO  constant  R G B A           [LABEL]
#   FROM  TO  ramp      R G B A  R G B A  [LABEL]
# A range covers the whole CT values FROM <= value < TO (half open, so neighbours can share a
# boundary; TO = 32768 reaches the highest value, 32767). R G B is a colour and A an opacity,
# all from 0 to 1; A holds for one unit of length (one voxel at spacing 1). A constant range
# has one colour and opacity; a ramp goes linearly from its first set at FROM to its second at
# TO. Ranges are sorted by FROM and must not overlap; values that no range covers are
# transparent. LABEL names a range for the command line: --skin-opacity sets the range "skin".
#
# from     to   kind      r    g     b    opacity   label
  -300     50   constant  1.0  0.79  0.6  0.12      skin
   300  32768   constant  1.0  1.0   1.0  0.8       bone
