#include "trace/triangle_bvh.h"
