// ctlab.h: the one header a step includes. It brings the boring code (common/) and the
// standard headers the steps use, so a step file starts with a single #include.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>
#include "args.h"
#include "bricks.h"
#include "camera_flags.h"
#include "dispatch.h"
#include "object_order.h"
#include "error.h"
#include "huge_pages.h"
#include "image.h"
#include "not_done.h"
#include "phantom.h"
#include "render.h"
#include "step.h"
#include "transfer_function.h"
#include "vec3.h"
#include "view.h"
#include "volume.h"
