// Region building blocks of GIA's colouring (gia_regions.cpp), shared by intersection_analysis.cpp (per-path and
// parity colourings) and cloth_untangling.cpp (per-component colouring in the step).
#pragma once

#include <vector>

#include "weft/gia/gia_result.h"

namespace weft {

// One third of each incident triangle's current area per vertex.
std::vector<double> lumped_vertex_area(const Positions& x, const Faces& f);

// Edges of mesh m crossed an odd number of times by the given hits (even crossings leave both
// endpoints on the same side): the walls of a colouring.
std::vector<int> odd_crossed_edges(const GiaResult& r, const std::vector<int>& hits, int m);

// Flood fill of the vertex graph without the edges whose wall_stamp equals `stamp` and without
// blocked vertices (set beforehand to region_stamp = stamp, region = -1). Each seed not yet
// reached starts a region; returns the regions' areas and seeds.
struct FloodFill {
  const GiaTopology& topo;
  const std::vector<double>& vertex_area;
  std::vector<int> wall_stamp, region_stamp, region, queue;

  FloodFill(const GiaTopology& t, const std::vector<double>& area)
      : topo(t), vertex_area(area), wall_stamp(t.edges.rows(), -1), region_stamp(area.size(), -1),
        region(area.size(), -1) {}

  void block(int v, int stamp) {
    region_stamp[v] = stamp;
    region[v] = -1;
  }

  void fill(const std::vector<int>& seeds, int stamp, std::vector<double>& region_area, std::vector<int>& region_seed) {
    for (int seed : seeds) {
      if (region_stamp[seed] == stamp) continue;
      const int id = static_cast<int>(region_area.size());
      region_area.push_back(0.0);
      region_seed.push_back(seed);
      queue.assign(1, seed);
      region_stamp[seed] = stamp;
      region[seed] = id;
      for (size_t q = 0; q < queue.size(); ++q) {
        const int v = queue[q];
        region_area[id] += vertex_area[v];
        for (int k = topo.vertex_offset[v]; k < topo.vertex_offset[v + 1]; ++k) {
          const int w = topo.vertex_neighbour[k];
          if (region_stamp[w] == stamp || wall_stamp[topo.vertex_edge[k]] == stamp) continue;
          region_stamp[w] = stamp;
          region[w] = id;
          queue.push_back(w);
        }
      }
    }
  }
};

}  // namespace weft
