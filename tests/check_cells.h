/* Reference cells the cell tests share (tests/test_volume.c,
 * tests/test_quality.c): one positively oriented cell of each linear 3D type,
 * in VTK node order, with its exact volume. */
#ifndef FFD_TEST_CHECK_CELLS_H
#define FFD_TEST_CHECK_CELLS_H

#include <stddef.h>
#include <stdint.h>

#include <ffd.h>

typedef struct {
    uint8_t type;
    size_t n;
    double p[8][3];
    double volume;
} ref_cell;

/* One positive cell of each linear 3D type, VTK node order. */
static const ref_cell refs[] = {
    {FFD_CELL_TETRA, 4, {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}, 1.0 / 6},
    {FFD_CELL_HEXAHEDRON, 8,
     {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}}, 1},
    {FFD_CELL_VOXEL, 8,
     {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {1, 1, 1}}, 1},
    {FFD_CELL_WEDGE, 6, {{0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}}, 0.5},
    {FFD_CELL_PYRAMID, 5, {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.5, 0.5, 1}}, 1.0 / 3},
};

#endif
