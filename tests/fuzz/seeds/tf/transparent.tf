# transparent.tf: every CT value fully transparent, for tests (nothing to shade, black image).
# Format: see classic.tf.
#
#   from     to   kind      r  g  b  opacity   label
  -32768  32768   constant  0  0  0  0         air
