// Test support: the faces of an n x n vertex grid (vertex i * n + j), two triangles per cell.
#pragma once

#include "weft/common/types.h"

namespace weft::testing {

inline Faces grid_faces(int n) {
  Faces faces(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      const int a = i * n + j, b = a + 1, c = a + n, d = c + 1;
      faces.row(f++) << a, b, d;
      faces.row(f++) << a, d, c;
    }
  return faces;
}

}  // namespace weft::testing
