# bone_only.tf: the classic bone range alone (no skin). Format: see classic.tf.
#
# from     to   kind      r    g    b    opacity   label
   300  32768   constant  1.0  1.0  1.0  0.8       bone
