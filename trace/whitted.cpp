#include "trace/whitted.h"
