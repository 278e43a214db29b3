#include "common/image.h"
