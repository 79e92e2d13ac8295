// Test support: the faces of an n x n vertex grid (vertex i * n + j), two triangles per cell.
#pragma once

#include "weft/common/types.h"

namespace weft::testing {

// Of a grid of `rows` x `columns` vertices (vertex i * columns + j).
inline Faces grid_faces(int rows, int columns) {
  Faces faces(2 * (rows - 1) * (columns - 1), 3);
  int f = 0;
  for (int i = 0; i + 1 < rows; ++i)
    for (int j = 0; j + 1 < columns; ++j) {
      const int a = i * columns + j, b = a + 1, c = a + columns, d = c + 1;
      faces.row(f++) << a, b, d;
      faces.row(f++) << a, d, c;
    }
  return faces;
}

inline Faces grid_faces(int n) { return grid_faces(n, n); }

}  // namespace weft::testing
