#include "slicer_modules.hpp"

#include "core/error.hpp"

#include <system_error>

#ifndef BS_README_URL
#define BS_README_URL "README.md"
#endif
#ifndef BS_VERSION
#define BS_VERSION "unknown"
#endif

namespace brainshift::apps::slicer {
namespace {

constexpr const char* kCategory = "Registration.Brain shift";
constexpr const char* kLicense =
    "No licence has been chosen for brainshift yet (see its README). Research software, not for "
    "clinical use.";
constexpr const char* kContributor = "The brainshift project";

Parameter image(const char* name, const char* label, const char* description, const char* channel,
                bool required, const char* attributes = "") {
  Parameter p;
  p.tag = "image";
  p.name = name;
  p.label = label;
  p.description = description;
  p.channel = channel;
  p.required = required;
  p.attributes = attributes;
  return p;
}

Parameter data(const char* tag, const char* name, const char* label, const char* description,
               const char* channel, bool required, const char* attributes = "") {
  Parameter p = image(name, label, description, channel, required, attributes);
  p.tag = tag;
  return p;
}

ModuleDescription common(const char* title, const char* description) {
  ModuleDescription m;
  m.category = kCategory;
  m.title = title;
  m.description = description;
  m.version = BS_VERSION;
  m.documentation_url = std::string(BS_README_URL) + "#using-brainshift-from-3d-slicer";
  m.license = kLicense;
  m.contributor = kContributor;
  m.acknowledgements =
      "Constraint-based ICP on a corotational tetrahedral FEM after Morin et al. 2017 (brain-shift "
      "compensation from navigated ultrasound vessels).";
  return m;
}

}  // namespace

ModuleDescription prepare_module() {
  ModuleDescription m = common(
      "Brainshift Prepare",
      "Builds the patient's biomechanical brain model before surgery: a tetrahedral mesh of the "
      "labelled brain, its collision surface, the vessel skeleton from the MR angiogram and the "
      "precomputed compliance block, written as a model folder for Brainshift Register.");
  ParameterGroup in{"Pre-operative images",
                    "Segmented MRI and MR angiogram of the same patient, in the same frame.",
                    false,
                    {}};
  in.parameters.push_back(
      image("labels", "Label map",
            "Label volume: 0 background, 1 brain, 2 tumour, 3 ventricles (any other value is "
            "an error).",
            "input", true, "type=\"label\""));
  in.parameters.push_back(image("mra", "MR angiogram",
                                "MR angiogram (bright vessels) in the frame of the label map.",
                                "input", true, "type=\"scalar\""));
  in.parameters.push_back(
      image("mri", "Pre-operative MRI (optional)",
            "Recorded in the model so that Brainshift Register can check it warps the same "
            "scan.",
            "input", false, "type=\"scalar\""));
  ParameterGroup out{"Model", "Where the model is written.", false, {}};
  out.parameters.push_back(
      data("directory", "model", "Model folder",
           "Folder for the model: new, empty, or an earlier brainshift model (replaced).", "output",
           true));
  ParameterGroup advanced{"Advanced", "Mesh resolution.", true, {}};
  Parameter refine;
  refine.tag = "double";
  refine.name = "refine";
  refine.label = "Mesh refinement";
  refine.description =
      "1 gives about 1.6k nodes on the phantoms; the node count grows about as refinement^2.7.";
  refine.default_value = "1.0";
  refine.minimum = "0.25";
  refine.maximum = "6.0";
  refine.step = "0.25";
  advanced.parameters.push_back(refine);
  Parameter vertices;
  vertices.tag = "integer";
  vertices.name = "surfaceVertices";
  vertices.label = "Collision surface vertices";
  vertices.description = "Size of the decimated collision surface.";
  vertices.default_value = "300";
  vertices.minimum = "20";
  vertices.maximum = "100000";
  vertices.step = "10";
  advanced.parameters.push_back(vertices);
  m.groups = {in, out, advanced};
  return m;
}

ModuleDescription register_module() {
  ModuleDescription m = common(
      "Brainshift Register",
      "Registers the brain model to the vessels of a tracked intra-operative power-Doppler volume "
      "(and the probe footprint in B-mode) and gives the brain's current shape: the warped "
      "pre-operative MRI and two displacement-field transforms. Apply 'Pre-op to intra-op' to "
      "pre-operative volumes, segmentations, models and markups to see them where they are now; "
      "apply 'Intra-op to pre-op' to the ultrasound or intra-operative points to bring them onto "
      "the pre-operative MRI.");
  ParameterGroup in{
      "Inputs", "The model from Brainshift Prepare and the intra-operative ultrasound.", false, {}};
  in.parameters.push_back(data("directory", "model", "Model folder",
                               "Model folder written by Brainshift Prepare.", "input", true));
  in.parameters.push_back(
      image("doppler", "Power Doppler",
            "Tracked power-Doppler volume (vessels), in the patient frame of the model.", "input",
            true, "type=\"scalar\""));
  in.parameters.push_back(
      image("bmode", "B-mode (optional)",
            "Tracked B-mode volume for the probe footprint; its k axis runs along the beam, "
            "k = 0 at the probe.",
            "input", false, "type=\"scalar\""));
  in.parameters.push_back(
      image("preDura", "Pre-dura power Doppler (optional)",
            "Tracked power-Doppler volume of a sweep on the dura before it was opened: the "
            "navigation offset is measured on it and kept, so the sag is not mistaken for a pose "
            "(far from the probe the warp is then right too).",
            "input", false, "type=\"scalar\""));
  in.parameters.push_back(
      data("file", "preDuraPose", "Stored pre-dura pose (optional)",
           "The same navigation offset measured beforehand (brainshift pre-dura, or a result "
           "folder's pre_dura_pose.json): no second extraction. Not with the pre-dura Doppler.",
           "input", false, "fileExtensions=\".json\""));
  in.parameters.push_back(
      image("preopMRI", "Pre-operative MRI (optional)",
            "The MRI to warp, on the grid of the model's label map; needed for the warped MRI.",
            "input", false, "type=\"scalar\""));
  ParameterGroup out{"Outputs", "Transforms, warped MRI and report.", false, {}};
  out.parameters.push_back(
      image("warpedMRI", "Warped MRI",
            "The pre-operative MRI deformed to the brain's current shape (needs the "
            "pre-operative MRI).",
            "output", false, "type=\"scalar\" fileExtensions=\".nrrd\""));
  out.parameters.push_back(
      data("transform", "preopToIntraop", "Pre-op to intra-op transform",
           "Displacement field that, applied to pre-operative content (MRI, segmentations, "
           "models, markups), shows it where it is now.",
           "output", false, "type=\"nonlinear\" fileExtensions=\".nrrd\""));
  out.parameters.push_back(
      data("transform", "intraopToPreop", "Intra-op to pre-op transform",
           "Displacement field that, applied to intra-operative content (ultrasound, tracked "
           "points), brings it onto the pre-operative MRI.",
           "output", false, "type=\"nonlinear\" fileExtensions=\".nrrd\""));
  out.parameters.push_back(
      data("file", "reportFile", "Report (JSON)",
           "Registration report: iterations, convergence, constraints, rigid start, timing.",
           "output", false, "fileExtensions=\".json\""));
  ParameterGroup advanced{"Advanced", "Rigid start and the full result folder.", true, {}};
  Parameter init;
  init.tag = "string-enumeration";
  init.name = "init";
  init.label = "Rigid start";
  init.description =
      "scene: the model's setting (a robust rigid fit); rigid: force it; identity: none.";
  init.elements = {"scene", "rigid", "identity"};
  init.default_value = "scene";
  advanced.parameters.push_back(init);
  advanced.parameters.push_back(
      data("directory", "resultDirectory", "Result folder (optional)",
           "Also write everything brainshift register writes (deformed mesh, fields, "
           "overlay, report) here: a new, empty or earlier result folder (replaced).",
           "output", false));
  m.groups = {in, out, advanced};
  return m;
}

void verify_replaceable_folder(const std::filesystem::path& dir, const char* marker) {
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec)) return;
  BS_VERIFY(std::filesystem::is_directory(dir, ec), dir.string() << ": exists and is not a folder");
  const bool empty = std::filesystem::is_empty(dir, ec);
  BS_VERIFY(!ec, dir.string() << ": cannot be read (" << ec.message() << ")");
  BS_VERIFY(empty || std::filesystem::exists(dir / marker, ec),
            dir.string() << ": holds other files and no " << marker
                         << "; it would be replaced whole, so choose a new or empty folder");
}

}  // namespace brainshift::apps::slicer
