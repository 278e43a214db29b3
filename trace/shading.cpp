#include "trace/shading.h"
