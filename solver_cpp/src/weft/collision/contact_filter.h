// What contact detection skips: the GIA one-way membranes (cloth/cloth untangling, cloth
// coloured inside a body, body faces in intersection with the cloth) and cloth in a body/body
// pinch region, queried per triangle pair and feature. The defaults skip nothing (GIA off);
// the collision system answers from the gia/ drivers.
#pragma once

namespace weft {

class ContactFilter {
 public:
  virtual ~ContactFilter() = default;
  // Cloth/cloth triangle pair across an intersection (cloth_untangling.h).
  virtual bool skip_cloth_pair(int /*cloth_face*/, int /*other_face*/) const { return false; }
  // Cloth vertex p coloured inside body `body`.
  virtual bool coloured(int /*p*/, int /*body*/) const { return false; }
  // Body face colouring: 3 all corners in the body's region in intersection, 2 some, 1 only
  // pierced by the cloth, 0 free.
  virtual int body_face_colour(int /*face*/, int /*body*/) const { return 0; }
  // Cloth face and body pierce each other.
  virtual bool cloth_face_contour(int /*cloth_face*/, int /*body*/) const { return false; }
  // Cloth face in a body/body pinch region of `body` (its pairs with the body get no CCD).
  virtual bool pinched_face(int /*cloth_face*/, int /*body*/) const { return false; }
  // Cloth vertex p is a corner of a cloth face on the contour with `body` (cloth_face_contour).
  virtual bool contour_corner(int /*p*/, int /*body*/) const { return false; }
  // Some cloth face is in a pinch region of `body`.
  virtual bool pinch_region(int /*body*/) const { return false; }
  // True when every query about pairs with `body` (cloth/cloth pairs: body < 0) would give
  // the default answer above: the expansion then asks none of them (one call per triangle pair
  // instead of one per feature). False here, so that a filter overriding the queries alone is
  // still asked.
  virtual bool skips_nothing(int /*body*/) const { return false; }
};

}  // namespace weft
