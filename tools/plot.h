// plot.h: the drawing moved to common/plot.h (the ray pictures of --debug-pixel use it too).
#pragma once
#include "common/plot.h"
