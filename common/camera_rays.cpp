#include "common/camera_rays.h"
