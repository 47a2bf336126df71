/*
 * ffd_methods.h — the registry of the methods' public headers.
 *
 * One line per method: its public header include/ffd_<method>.h, which holds
 * the method's own handle, options and operations. ffd.h includes this list
 * at its end, so `#include <ffd.h>` gives every method's API. Adding a
 * method adds one line here (docs/architecture.md, "Adding a method").
 * Their guards are FFD_<METHOD>_API_H (FFD_<METHOD>_H is the library's
 * internal header of the method).
 */
#ifndef FFD_METHODS_H
#define FFD_METHODS_H

#include "ffd_lattice.h"
#include "ffd_pbffd.h"
#include "ffd_gffd.h"
#include "ffd_tspline.h"
#include "ffd_cage.h"
#include "ffd_kelvinlet.h"
#include "ffd_rbf.h"
#include "ffd_idw.h"

#endif /* FFD_METHODS_H */
