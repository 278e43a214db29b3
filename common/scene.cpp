#include "common/scene.h"
