#include "apps/workflow/result_fields.hpp"

#include "apps/workflow/intraop_frame.hpp"
#include "core/error.hpp"
#include "imaging/warping/warp_image.hpp"

#include <future>
#include <utility>

namespace brainshift::workflow {
namespace {

/// displacement and intraop_to_preop: one rasterisation for both (they differ only by the
/// extension shell beyond the mesh).
void forward_fields(const Session& s, ResultFields& f) {
  const imaging::ImageGeometry& preop = s.loaded.preop_grid;
  imaging::DisplacementFieldOptions slicer;
  slicer.rigid = f.intraop_from_model.matrix();
  slicer.extension_mm = imaging::trilinear_support_mm(preop);
  imaging::ForwardDisplacementFields forward =
      imaging::displacement_fields(s.model->mesh(), f.u_intra, preop, slicer);
  f.displacement = std::move(forward.exact);
  f.intraop_to_preop = std::move(forward.extended);
}

/// preop_to_intraop: where pre-operative content is now, on the pre-operative grid moved by the
/// rigid part (its lattice, so no larger than the pre-operative grid unless the deformed brain
/// leaves it) grown to cover the deformed brain.
void inverse_field(const Session& s, ResultFields& f) {
  const core::TetMesh& mesh = s.model->mesh();
  const imaging::ImageGeometry& preop = s.loaded.preop_grid;
  imaging::DisplacementFieldOptions slicer;
  slicer.rigid = f.intraop_from_model.matrix();
  slicer.extension_mm = imaging::trilinear_support_mm(preop);
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
}

}  // namespace

void compute_result_fields(const Session& s, const constraints::RegistrationResult& r,
                           const imaging::VolumeF* mri, bool with_uncertainty, int threads,
                           ResultFields& f, const ResultPartReady& ready) {
  const core::TetMesh& mesh = s.model->mesh();
  BS_VERIFY(r.positions.rows() == mesh.num_nodes(), "the registration result has "
                                                        << r.positions.rows() << " positions for "
                                                        << mesh.num_nodes() << " nodes");
  BS_VERIFY(threads >= 1, "compute_result_fields: threads must be ≥ 1, got " << threads);
  f.intraop_from_model = intraop_from_model(r);
  f.u_intra = to_intraop_frame(r, r.positions) - mesh.nodes();
  const auto hand_over = [&](ResultPart part) {
    if (ready) ready(part);
  };
  // The second lane: the inverse field, the warped MRI and the predicted error. Only this lane
  // solves with the model (the predicted error); the other one only rasterises.
  const auto second_lane = [&] {
    inverse_field(s, f);
    hand_over(ResultPart::INVERSE);
    if (mri) {
      imaging::WarpOptions wo;
      wo.rigid = f.intraop_from_model.matrix();
      f.warped_mri = imaging::warp_image(*mri, mesh, f.u_intra, wo);
      hand_over(ResultPart::WARPED_MRI);
    }
    if (with_uncertainty) {
      f.uncertainty = compute_result_uncertainty(s, r);
      hand_over(ResultPart::UNCERTAINTY);
    }
  };
  if (threads == 1) {
    forward_fields(s, f);
    hand_over(ResultPart::FORWARD);
    second_lane();
    return;
  }
  // The future's destructor waits for the lane, also when the calling thread's part throws.
  std::future<void> lane = std::async(std::launch::async, second_lane);
  forward_fields(s, f);
  hand_over(ResultPart::FORWARD);
  lane.get();
}

ResultFields compute_result_fields(const Session& s, const constraints::RegistrationResult& r,
                                   const imaging::VolumeF* mri, bool with_uncertainty) {
  ResultFields f;
  compute_result_fields(s, r, mri, with_uncertainty, /*threads=*/2, f, {});
  return f;
}

}  // namespace brainshift::workflow
