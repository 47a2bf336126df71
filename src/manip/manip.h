/* manip — direct manipulation, generic over linear deformers (ffd_linear_map). */
#ifndef FFD_MANIP_H
#define FFD_MANIP_H

#include "core/core.h"

#endif
