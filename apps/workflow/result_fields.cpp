#include "apps/workflow/result_fields.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "core/error.hpp"
#include "imaging/warping/warp_image.hpp"

#include <utility>

namespace brainshift::workflow {

ResultFields compute_result_fields(const Session& s, const constraints::RegistrationResult& r,
                                   const imaging::VolumeF* mri, bool with_uncertainty) {
  const core::TetMesh& mesh = s.model->mesh();
  BS_VERIFY(r.positions.rows() == mesh.num_nodes(), "the registration result has "
                                                        << r.positions.rows() << " positions for "
                                                        << mesh.num_nodes() << " nodes");
  ResultFields f;
  f.intraop_from_model = intraop_from_model(r);
  f.u_intra = to_intraop_frame(r, r.positions) - mesh.nodes();

  const imaging::ImageGeometry& preop = s.loaded.preop_grid;
  imaging::DisplacementFieldOptions fo;
  fo.rigid = f.intraop_from_model.matrix();
  imaging::DisplacementFieldOptions slicer = fo;
  slicer.extension_mm = imaging::trilinear_support_mm(preop);
  // One rasterisation for both: they differ only by the extension shell beyond the mesh.
  imaging::ForwardDisplacementFields forward =
      imaging::displacement_fields(mesh, f.u_intra, preop, slicer);
  f.displacement = std::move(forward.exact);
  f.intraop_to_preop = std::move(forward.extended);
  // Where pre-operative content is now: the pre-operative grid moved by the rigid part (its
  // lattice, so no larger than the pre-operative grid unless the deformed brain leaves it) and
  // the deformed brain.
  imaging::ImageGeometry moved = preop;
  moved.origin = f.intraop_from_model * preop.origin;
  moved.direction = f.intraop_from_model.linear() * preop.direction;
  MatrixX3d now(8 + mesh.num_nodes(), 3);
  for (int c = 0; c < 8; ++c) {
    const Vector3d ijk((c & 1) ? preop.size[0] - 1 : 0, (c & 2) ? preop.size[1] - 1 : 0,
                       (c & 4) ? preop.size[2] - 1 : 0);
    now.row(c) = moved.index_to_world(ijk).transpose();
  }
  now.bottomRows(mesh.num_nodes()) = mesh.nodes() + f.u_intra;
  const imaging::ImageGeometry intra = imaging::covering_grid(moved, now, /*margin_mm=*/0.0);
  f.preop_to_intraop = imaging::inverse_displacement_field(mesh, f.u_intra, intra, slicer);

  if (mri) {
    imaging::WarpOptions wo;
    wo.rigid = f.intraop_from_model.matrix();
    f.warped_mri = imaging::warp_image(*mri, mesh, f.u_intra, wo);
  }
  if (with_uncertainty) f.uncertainty = compute_result_uncertainty(s, r);
  return f;
}

}  // namespace brainshift::workflow
