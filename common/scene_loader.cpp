#include "common/scene_loader.h"
