#include "volcast/assets/case.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <set>

#include "volcast/assets/label_volume.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

const std::set<std::string> kMeshExtensions{".obj", ".stl", ".ply", ".gltf",
                                            ".glb", ".off", ".dae"};

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

// Without case.json: the liver with its vessels, tumours and gallbladder is one object, the rest
// of the body another.
std::string default_group(const std::string& name) {
  const std::string n = lower(name);
  for (const char* s : {"liver", "porta", "hepatic", "cava", "tumo", "gall"})
    if (n.find(s) != std::string::npos) return "liver";
  return "body";
}

struct LabelPartSpec {
  std::string name;
  LabelSelector selector;
  bool components = false;
  size_t min_voxels = 10;
};

// 3D-IRCADb's label volumes: structures as bit flags (shared data README).
const std::vector<LabelPartSpec>& ircad_structures() {
  static const std::vector<LabelPartSpec> specs{{"liver", {448, 448}, false, 10},
                                                {"tumour", {2, 2}, true, 10},
                                                {"portal vein", {16, 16}, false, 10},
                                                {"hepatic veins", {32, 32}, false, 10}};
  return specs;
}

CasePart finish(CasePart part, const Eigen::Vector4f& rgba) {
  part.rgba = rgba;
  part.bbox_mm = bounding_box(part.mesh);
  part.closed = is_closed(part.mesh);
  part.volume_ml = enclosed_volume(part.mesh) / 1000.0;
  return part;
}

void add_label_parts(Case& c, const fs::path& file, const LabelVolume& volume,
                     const LabelPartSpec& spec, const std::string& group,
                     std::optional<Eigen::Vector4f> rgba, const SurfaceOptions& surface,
                     const CaseLoadOptions& options) {
  if (options.progress) options.progress("labels: " + spec.name);
  const MaskComponent structure = select_box(volume, spec.selector);
  const auto make = [&](const std::string& name, const MaskComponent& m) {
    CasePart p;
    p.name = name;
    p.group = group;
    p.source = file;
    p.mesh = extract_surface(volume, m, surface);
    p.voxels = m.voxels;
    p.voxel_volume_ml = static_cast<double>(m.voxels) * volume.voxel_volume_mm3() / 1000.0;
    if (p.mesh.indices.empty()) return;
    c.parts.push_back(finish(std::move(p), rgba.value_or(default_part_rgba(spec.name))));
  };
  if (!spec.components) {
    make(spec.name, structure);
    return;
  }
  const std::vector<MaskComponent> parts = connected_components(structure, spec.min_voxels);
  if (c.parts.size() + parts.size() > kMaxCaseParts)
    throw Error(file.filename().string() + ": '" + spec.name + "' has " +
                std::to_string(parts.size()) + " components of at least " +
                std::to_string(spec.min_voxels) + " voxels; a case holds at most " +
                std::to_string(kMaxCaseParts) + " parts: raise min_voxels");
  for (size_t i = 0; i < parts.size(); ++i) make(spec.name + " " + std::to_string(i + 1), parts[i]);
}

Eigen::Vector4f rgba_from(const json& j, const std::string& name) {
  Eigen::Vector4f rgba = default_part_rgba(name);
  if (j.contains("color")) {
    const json& c = j.at("color");
    if (!c.is_array() || c.size() != 3) throw Error("part '" + name + "': color must be [r, g, b]");
    for (int i = 0; i < 3; ++i) rgba[i] = std::clamp(c.at(i).get<float>(), 0.0f, 1.0f);
  }
  if (j.contains("opacity")) rgba[3] = std::clamp(j.at("opacity").get<float>(), 0.0f, 1.0f);
  return rgba;
}

fs::path inside(const fs::path& folder, const std::string& relative, const std::string& what) {
  const fs::path p = folder / relative;
  std::error_code ec;
  if (!fs::exists(p, ec)) throw Error(what + " " + p.string() + ": no such file or folder");
  return p;
}

bool has_dicom(const fs::path& folder) {
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.is_regular_file() && is_dicom_file(e.path())) return true;
  return false;
}

// The SEG files among a folder's DICOM files.
std::vector<fs::path> seg_files(const fs::path& folder) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    if (!e.is_regular_file()) continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::string head(4096, '\0');
    in.read(head.data(), head.size());
    head.resize(in.gcount());
    if (head.size() > 132 && head.substr(128, 4) == "DICM" &&
        head.find("1.2.840.10008.5.1.4.1.1.66.4") != std::string::npos)
      out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

void load_dicom(Case& c, const fs::path& series, const std::optional<fs::path>& seg,
                const std::string& segment, const CaseLoadOptions& options) {
  if (options.progress) options.progress("DICOM " + series.filename().string());
  c.dicom = read_dicom_series(series);
  if (seg) read_dicom_seg(*seg, *c.dicom, segment);
}

// case.json, read (at most kMaxCaseJsonBytes) and parsed: a JSON object.
json read_spec(const fs::path& spec_file) {
  std::error_code ec;
  if (const uintmax_t bytes = fs::file_size(spec_file, ec); !ec && bytes > kMaxCaseJsonBytes)
    throw Error("case.json is " + std::to_string(bytes) + " bytes; at most " +
                std::to_string(kMaxCaseJsonBytes) + " are read");
  std::ifstream in(spec_file);
  json spec;
  try {
    spec = json::parse(in);
  } catch (const json::exception& e) {
    throw Error(std::string("case.json does not parse: ") + e.what());
  }
  if (!spec.is_object()) throw Error("case.json is not a JSON object");
  return spec;
}

// case.json's "name", "orientation" (lps or room) and "max_triangles".
void apply_spec_settings(Case& c, const json& spec, SurfaceOptions& surface) {
  c.name = spec.value("name", c.name);
  const std::string orientation = spec.value("orientation", std::string("lps"));
  if (orientation == "room")
    c.room_from_case.setIdentity();
  else if (orientation != "lps")
    throw Error("case.json: orientation '" + orientation + "' is neither lps nor room");
  surface.max_triangles = spec.value("max_triangles", surface.max_triangles);
  if (surface.max_triangles < 1 || surface.max_triangles > kMaxPartTriangles)
    throw Error("case.json: max_triangles " + std::to_string(surface.max_triangles) +
                " is not in 1.." + std::to_string(kMaxPartTriangles));
}

// case.json's "parts": each a mesh file, or the surface of a label volume's selected labels (one
// part, or one per connected component); a label volume read once for all its parts.
void load_spec_parts(Case& c, const fs::path& folder, const json& spec,
                     const SurfaceOptions& surface, const CaseLoadOptions& options) {
  const json parts = spec.value("parts", json::array());
  if (!parts.is_array()) throw Error("case.json: \"parts\" is not an array");
  if (parts.size() > kMaxCaseParts)
    throw Error("case.json declares " + std::to_string(parts.size()) +
                " parts; a case holds at most " + std::to_string(kMaxCaseParts));
  std::map<fs::path, LabelVolume> volumes;
  for (const json& part : parts) {
    const std::string name = part.at("name").get<std::string>();
    const std::string group = part.value("group", name);
    const Eigen::Vector4f rgba = rgba_from(part, name);
    if (part.contains("mesh")) {
      const fs::path file =
          inside(folder, part.at("mesh").get<std::string>(), "part '" + name + "':");
      if (options.progress) options.progress(file.filename().string());
      if (c.parts.size() >= kMaxCaseParts)
        throw Error("case.json: more than " + std::to_string(kMaxCaseParts) + " parts");
      CasePart p;
      p.name = name, p.group = group, p.source = file;
      p.mesh = read_mesh_file(file);
      c.parts.push_back(finish(std::move(p), rgba));
    } else if (part.contains("labels")) {
      const fs::path file =
          inside(folder, part.at("labels").get<std::string>(), "part '" + name + "':");
      if (!volumes.count(file)) volumes.emplace(file, read_label_volume(file));
      LabelPartSpec s{name,
                      {part.value("mask", -1), part.value("value", 1)},
                      part.value("components", false),
                      part.value("min_voxels", size_t{10})};
      add_label_parts(c, file, volumes.at(file), s, group, rgba, surface, options);
    } else {
      throw Error("case.json: part '" + name + "' has neither \"mesh\" nor \"labels\"");
    }
  }
}

// A folder with case.json: its settings, its parts, and its "dicom" series (and SEG) if named.
void load_from_spec(Case& c, const fs::path& folder, const fs::path& spec_file,
                    SurfaceOptions& surface, const CaseLoadOptions& options) {
  const json spec = read_spec(spec_file);
  apply_spec_settings(c, spec, surface);
  load_spec_parts(c, folder, spec, surface, options);
  if (spec.contains("dicom")) {
    const json& d = spec.at("dicom");
    const fs::path series = inside(folder, d.at("series").get<std::string>(), "DICOM series");
    std::optional<fs::path> seg;
    if (d.contains("seg")) seg = inside(folder, d.at("seg").get<std::string>(), "DICOM SEG");
    load_dicom(c, series, seg, d.value("segment", std::string()), options);
  }
}

// A folder without case.json: every mesh file as a part (grouped by default_group), every .vti
// as 3D-IRCADb label volume (its structures), in file name order.
void load_folder_parts(Case& c, const fs::path& folder, const SurfaceOptions& surface,
                       const CaseLoadOptions& options) {
  std::error_code ec;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.is_regular_file()) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  const auto meshes = std::count_if(files.begin(), files.end(), [](const fs::path& f) {
    return kMeshExtensions.count(lower(f.extension().string())) > 0;
  });
  if (static_cast<size_t>(meshes) > kMaxCaseParts)
    throw Error("the folder holds " + std::to_string(meshes) +
                " mesh files; a case holds at most " + std::to_string(kMaxCaseParts) +
                " parts (list the ones to load in a case.json)");
  for (const fs::path& f : files) {
    const std::string ext = lower(f.extension().string());
    if (kMeshExtensions.count(ext)) {
      if (options.progress) options.progress(f.filename().string());
      CasePart p;
      p.name = f.stem().string(), p.source = f;
      std::replace(p.name.begin(), p.name.end(), '_', ' ');
      p.group = default_group(p.name);
      p.mesh = read_mesh_file(f);
      // The colour before the move: argument order is unspecified (Clang moves p first).
      const Eigen::Vector4f rgba = default_part_rgba(p.name);
      c.parts.push_back(finish(std::move(p), rgba));
    } else if (ext == ".vti") {
      const LabelVolume volume = read_label_volume(f);
      for (const LabelPartSpec& s : ircad_structures())
        add_label_parts(c, f, volume, s, default_group(s.name), std::nullopt, surface, options);
    }
  }
}

// The folder holding a DICOM series: the case folder itself, else its first subfolder (by name)
// with DICOM files; none if neither.
std::optional<fs::path> find_dicom_series(const fs::path& folder) {
  if (has_dicom(folder)) return folder;
  std::error_code ec;
  std::vector<fs::path> subs;
  for (const auto& e : fs::directory_iterator(folder, ec))
    if (e.is_directory()) subs.push_back(e.path());
  std::sort(subs.begin(), subs.end());
  for (const fs::path& s : subs)
    if (has_dicom(s)) return s;
  return std::nullopt;
}

// A folder without case.json: its mesh files and label volumes, and a DICOM series found in it
// (with the first SEG file beside it).
void load_from_files(Case& c, const fs::path& folder, const SurfaceOptions& surface,
                     const CaseLoadOptions& options) {
  load_folder_parts(c, folder, surface, options);
  if (const std::optional<fs::path> series = find_dicom_series(folder)) {
    const std::vector<fs::path> segs = seg_files(*series);
    load_dicom(c, *series, segs.empty() ? std::nullopt : std::optional(segs.front()), "", options);
  }
}

}  // namespace

std::vector<std::string> Case::groups() const {
  std::vector<std::string> out;
  for (const CasePart& p : parts)
    if (std::find(out.begin(), out.end(), p.group) == out.end()) out.push_back(p.group);
  return out;
}

Eigen::Vector4f default_part_rgba(const std::string& name) {
  const std::string n = lower(name);
  const auto has = [&](const char* s) { return n.find(s) != std::string::npos; };
  if (has("tumo")) return {0.95f, 0.85f, 0.15f, 1};
  if (has("porta") || has("portal")) return {0.85f, 0.35f, 0.75f, 1};
  if (has("cava") || has("hepatic") || has("ven")) return {0.15f, 0.3f, 0.9f, 1};
  if (has("aort") || has("arter")) return {0.85f, 0.08f, 0.08f, 1};
  if (has("liver")) return {0.55f, 0.2f, 0.13f, 0.5f};  // the shell: vessels show through
  if (has("gall")) return {0.2f, 0.65f, 0.2f, 1};
  if (has("kidney")) return {0.6f, 0.3f, 0.25f, 1};
  if (has("suprarrenal") || has("adrenal")) return {0.9f, 0.6f, 0.2f, 1};
  if (has("bone")) return {0.92f, 0.9f, 0.8f, 1};
  if (has("skin")) return {0.9f, 0.72f, 0.6f, 0.3f};
  return {0.8f, 0.8f, 0.8f, 1};
}

Case load_case(const fs::path& folder, const CaseLoadOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw Error("case " + folder.string() + ": not a folder");
  Case c;
  c.folder = folder;
  c.name = fs::absolute(folder).lexically_normal().filename().string();
  if (c.name.empty()) c.name = fs::absolute(folder).parent_path().filename().string();
  // LPS: L -> -z, P -> -y (anterior up), S -> -x (the head towards -x).
  Eigen::Matrix3f lps;
  lps << 0, 0, -1, 0, -1, 0, -1, 0, 0;
  c.room_from_case = lps;
  SurfaceOptions surface;
  surface.max_triangles = options.max_triangles;
  const fs::path spec_file = folder / "case.json";
  try {
    if (fs::exists(spec_file, ec))
      load_from_spec(c, folder, spec_file, surface, options);
    else
      load_from_files(c, folder, surface, options);
  } catch (const json::exception& e) {
    throw Error("case " + folder.string() + ": case.json: " + e.what());
  } catch (const Error& e) {
    throw Error("case " + folder.string() + ": " + e.what());
  }
  if (c.parts.empty() && !c.dicom)
    throw Error("case " + folder.string() +
                ": nothing in it (no mesh files, .vti label volumes, DICOM images or case.json)");
  c.load_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return c;
}

std::string case_json(const Case& c) {
  json j;
  j["name"] = c.name;
  j["load_ms"] = std::round(c.load_ms * 10) / 10;
  j["parts"] = json::array();
  for (const CasePart& p : c.parts) {
    json q{{"name", p.name},
           {"group", p.group},
           {"triangles", p.mesh.triangles()},
           {"volume_ml", std::round(p.volume_ml * 1000) / 1000},
           {"closed", p.closed},
           {"bbox_mm",
            {{p.bbox_mm.min.x(), p.bbox_mm.min.y(), p.bbox_mm.min.z()},
             {p.bbox_mm.max.x(), p.bbox_mm.max.y(), p.bbox_mm.max.z()}}},
           {"opacity", p.rgba[3]}};
    if (p.voxels) {
      q["voxels"] = p.voxels;
      q["voxel_volume_ml"] = std::round(p.voxel_volume_ml * 1000) / 1000;
    }
    j["parts"].push_back(q);
  }
  if (c.dicom) {
    const DicomSeries& d = *c.dicom;
    j["dicom"] = {{"slices", d.slices},
                  {"width", d.width},
                  {"height", d.height},
                  {"spacing_mm", {d.spacing_mm.x(), d.spacing_mm.y(), d.spacing_mm.z()}}};
    if (!d.overlay.empty()) j["dicom"]["overlay"] = d.overlay_label;
  }
  return j.dump(2);
}

}  // namespace volcast
