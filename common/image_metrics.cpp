#include "common/image_metrics.h"
