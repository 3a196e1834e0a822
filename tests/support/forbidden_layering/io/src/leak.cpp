// Not compiled: cmake/CheckLayering.cmake must reject this tree (io may not include lcm).
#include "dynfilter/core/types.hpp"
#include "dynfilter/lcm/messages.hpp"
