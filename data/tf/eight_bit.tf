# eight_bit.tf: for 8-bit volumes (values 0..255, e.g. foot_256x256x256_uint8.raw): faint
# tissue from 30, an opaque surface from 60. The format is described in classic.tf.
#
# from   to   kind      r    g    b    opacity   label
    30   60   constant  0.9  0.6  0.5  0.05      skin
    60  256   constant  1.0  1.0  0.95 0.6       bone
