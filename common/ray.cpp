#include "common/ray.h"
