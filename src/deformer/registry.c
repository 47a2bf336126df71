/* registry — the table of deformation methods (method.h). One line per method. */
#include "deformer/method.h"

#include <stdio.h>
#include <string.h>

/* The descriptors (one file each, src/<method>/<method>_method.c). */
extern const ffd_method ffd_method_lattice;
extern const ffd_method ffd_method_pbffd;
extern const ffd_method ffd_method_gffd;
extern const ffd_method ffd_method_tspline;
extern const ffd_method ffd_method_cage;
extern const ffd_method ffd_method_kelvinlet;
extern const ffd_method ffd_method_rbf;
extern const ffd_method ffd_method_idw;

static const ffd_method *const registry[] = {
    &ffd_method_lattice,
    &ffd_method_pbffd,
    &ffd_method_gffd,
    &ffd_method_tspline,
    &ffd_method_cage,
    &ffd_method_kelvinlet,
    &ffd_method_rbf,
    &ffd_method_idw,
};

size_t ffd_method_count(void)
{
    return sizeof registry / sizeof *registry;
}

const ffd_method *ffd_method_at(size_t i)
{
    return i < ffd_method_count() ? registry[i] : NULL;
}

const ffd_method *ffd_method_find(const char *name)
{
    for (size_t i = 0; name && i < ffd_method_count(); i++)
        if (!strcmp(registry[i]->name, name))
            return registry[i];
    return NULL;
}

const ffd_method *ffd_method_of_rig(const ffd_rig *rig)
{
    return rig ? rig->method : NULL;
}

const ffd_method *ffd_method_default(void)
{
    return registry[0];
}

int ffd_method_op_known(const char *op)
{
    for (size_t i = 0; op && i < ffd_method_count(); i++)
        for (const char *const *o = registry[i]->ops; o && *o; o++)
            if (!strcmp(*o, op))
                return 1;
    return 0;
}

const char *ffd_method_names(char *buf, size_t size)
{
    size_t used = 0, count = ffd_method_count();
    if (size)
        buf[0] = 0;
    for (size_t i = 0; i < count && used < size; i++) {
        const char *sep = i == 0 ? "" : i + 1 == count ? " or " : ", ";
        int w = snprintf(buf + used, size - used, "%s\"%s\"", sep, registry[i]->name);
        used += w > 0 ? (size_t)w : 0;
    }
    return buf;
}
