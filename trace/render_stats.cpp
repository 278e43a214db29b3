#include "trace/render_stats.h"
