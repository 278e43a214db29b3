#include "common/procedural.h"
