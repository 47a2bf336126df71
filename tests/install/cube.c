/* A program built against an installed libffd (tests/install/test_install.sh,
 * once with pkg-config and once with find_package(ffd)): a Bernstein lattice
 * of 2x2x2 control points (trilinear, Sederberg-Parry eq. 1) fitted to the
 * unit cube; moving its corner (1,1,1) by +0.5 in x moves that corner of the
 * cube by 0.5 and the centre by 0.5/8 (the corner's weight there is 1/8). */
#include <ffd.h>

#include <math.h>
#include <stdio.h>

int main(void)
{
    const double cube[9 * 3] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0, 0, 1,
                                1, 0, 1, 0, 1, 1, 1, 1, 1, 0.5, 0.5, 0.5};
    ffd_error err = {{0}};
    ffd_box box;
    ffd_lattice *lattice = NULL;
    ffd_lattice_binding *binding = NULL;
    const uint32_t res[3] = {2, 2, 2}, corner[3] = {1, 1, 1};
    const double delta[3] = {0.5, 0, 0};
    double out[9 * 3];
    if (ffd_box_fit(cube, 9, 0, &box, &err) != FFD_OK ||
        ffd_lattice_create(FFD_BASIS_BERNSTEIN, &box, res, &lattice, &err) != FFD_OK ||
        ffd_lattice_bind(lattice, cube, 9, FFD_OUTSIDE_FIXED, &binding, &err) != FFD_OK ||
        ffd_lattice_move(lattice, corner, delta, &err) != FFD_OK ||
        ffd_lattice_eval(lattice, binding, out, &err) != FFD_OK) {
        fprintf(stderr, "cube: %s\n", err.message);
        return 1;
    }
    ffd_lattice_binding_destroy(binding);
    ffd_lattice_destroy(lattice);
    printf("ffd %d.%d.%d: corner x %.17g, centre x %.17g\n", FFD_VERSION_MAJOR, FFD_VERSION_MINOR,
           FFD_VERSION_PATCH, out[7 * 3], out[8 * 3]);
    return fabs(out[7 * 3] - 1.5) <= 1e-12 && fabs(out[8 * 3] - 0.5625) <= 1e-12 ? 0 : 1;
}
