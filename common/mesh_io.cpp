#include "common/mesh_io.h"
