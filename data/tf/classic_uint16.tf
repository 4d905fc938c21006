# classic_uint16.tf: the classic table (classic.tf) for CT stored unsigned as Hounsfield units
# + 1024: every FROM and TO is classic.tf's plus 1024. The format is described in classic.tf.
#
# from     to   kind      r    g     b    opacity   label
   724   1074   constant  1.0  0.79  0.6  0.12      skin
  1324  32768   constant  1.0  1.0   1.0  0.8       bone
