#include "common/data_path.h"
