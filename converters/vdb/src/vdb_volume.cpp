#include "tetlod/converters/vdb.hpp"
