#include "trace/scene_bvh.h"
