#include "tetlod/converters/hdf5.hpp"
