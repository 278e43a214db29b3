#include "common/mesh.h"
