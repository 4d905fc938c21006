# float.tf: for float32 volumes scaled to 0..1 (e.g. an 8-bit volume divided by 255): faint
# tissue from 0.12, an opaque surface from 0.3. FROM and TO are in the file's own units: the
# volume's map turns them into its int16 values (the "units:" line says into which). TO = 2
# reaches past the top value 1. The format is described in classic.tf.
#
# from   to   kind      r    g    b    opacity   label
  0.12  0.3   constant  0.9  0.6  0.5  0.05      skin
  0.3   2     constant  1.0  1.0  0.95 0.6       bone
