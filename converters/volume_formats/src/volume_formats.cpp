#include "tetlod/converters/volume_formats.hpp"
