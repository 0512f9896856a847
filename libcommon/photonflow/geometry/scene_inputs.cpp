// The files a scene references, checked before any loader opens them: see scene_inputs.h.
#include "photonflow/geometry/scene_inputs.h"

#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "photonflow/foundations/error.h"
#include "photonflow/geometry/environment.h"
#include "photonflow/geometry/gltf_json.h"

namespace pf {

namespace {

namespace fs = std::filesystem;

// The folder part of `file` with its '/' ("" for a bare name: the working folder).
std::string folder_of(const std::string& file) {
  const size_t slash = file.find_last_of('/');
  return slash == std::string::npos ? std::string() : file.substr(0, slash + 1);
}

// A reference as the loader resolves it: absolute as given, else relative to the scene's folder.
std::string resolve(const std::string& scene_file, std::string rel) {
  std::replace(rel.begin(), rel.end(), '\\', '/');  // Windows exporters
  if (!rel.empty() && rel[0] == '/') return rel;
  return folder_of(scene_file) + rel;
}

// A reference shortened for a message (a data: URI may be megabytes long).
std::string shown(const std::string& s) {
  std::string out = s.size() > 80 ? s.substr(0, 77) + "..." : s;
  for (char& c : out)
    if (static_cast<unsigned char>(c) < 0x20) c = '?';
  return out;
}

// RFC 3986 percent-decoding of a glTF URI (glTF 2.0 §3.6.1: URIs are percent-encoded).
std::string percent_decode(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += char(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

// The whole of a small text file (a scene's JSON, OBJ or MTL), already checked to be regular.
std::string read_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw input_error(path, "cannot read the file", "check its permissions");
  std::ostringstream os;
  os << in.rdbuf();
  return os.str();
}

// How the check of a scene's references reads its glTF JSON (gltf_json.h): its own line for a
// file it cannot open, and a .glb's JSON chunk bounded by the file alone.
constexpr GltfJsonRead kReadAsReference{"cannot read the file", "check its permissions", false};

// Whether a data: URI is one assimp can decode: "data:<mime>;base64,<base64>".
bool good_data_uri(const std::string& uri) {
  const size_t comma = uri.find(',');
  if (comma == std::string::npos) return false;
  const std::string head = uri.substr(0, comma);
  if (head.size() < 7 || head.compare(head.size() - 7, 7, ";base64") != 0) return false;
  size_t n = 0, pad = 0;
  for (size_t i = comma + 1; i < uri.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(uri[i]);
    if (c == '=') {
      ++pad;
    } else if (pad || !(std::isalnum(c) || c == '+' || c == '/')) {
      return false;
    }
    ++n;
  }
  return n > 0 && n % 4 == 0 && pad <= 2;
}

const nlohmann::json* array_item(const nlohmann::json& doc, const char* key, const nlohmann::json& index) {
  if (!index.is_number_integer()) return nullptr;
  const auto it = doc.find(key);
  if (it == doc.end() || !it->is_array()) return nullptr;
  const long long i = index.get<long long>();
  if (i < 0 || size_t(i) >= it->size()) return nullptr;
  return &(*it)[size_t(i)];
}

// Why the texture `ref` (a textureInfo: {"index": i}) of a material cannot be read, "" if it can.
std::string texture_problem(const nlohmann::json& doc, const nlohmann::json& ref) {
  if (!ref.is_object() || !ref.contains("index")) return "has a texture reference without an index";
  const nlohmann::json* tex = array_item(doc, "textures", ref["index"]);
  if (!tex || !tex->is_object()) return "uses texture " + ref["index"].dump() + ", which the file does not have";
  if (!tex->contains("source"))
    return "uses texture " + ref["index"].dump() + ", which has no image source";
  const nlohmann::json* img = array_item(doc, "images", (*tex)["source"]);
  if (!img || !img->is_object())
    return "uses texture " + ref["index"].dump() + ", whose image " + (*tex)["source"].dump() +
           " the file does not have";
  const std::string which = "image " + (*tex)["source"].dump();
  if (img->contains("uri")) {
    const nlohmann::json& u = (*img)["uri"];
    if (!u.is_string() || u.get<std::string>().empty()) return "uses " + which + ", whose URI is empty";
    const std::string uri = u.get<std::string>();
    if (uri.rfind("data:", 0) == 0 && !good_data_uri(uri))
      return "uses " + which + ", whose data: URI is not base64 data assimp can decode";
    return {};
  }
  if (img->contains("bufferView")) {
    const nlohmann::json* view = array_item(doc, "bufferViews", (*img)["bufferView"]);
    if (!view || !view->is_object()) return "uses " + which + ", whose bufferView the file does not have";
    const auto len = view->find("byteLength");
    if (len == view->end() || !len->is_number() || !(len->get<double>() > 0))
      return "uses " + which + ", whose bufferView is empty";
    return {};
  }
  return "uses " + which + ", which has neither a URI nor a bufferView";
}

void gltf_references(const std::string& file, const InputPolicy& policy,
                     std::vector<std::string>& warnings, std::vector<SceneReference>& out) {
  nlohmann::json doc = gltf_json(file, kReadAsReference);
  if (!doc.is_object()) return;
  for (const char* key : {"buffers", "images"}) {
    const auto list = doc.find(key);
    if (list == doc.end() || !list->is_array()) continue;
    for (size_t i = 0; i < list->size(); ++i) {
      const nlohmann::json& item = (*list)[i];
      if (!item.is_object() || !item.contains("uri") || !item["uri"].is_string()) continue;
      const std::string uri = item["uri"].get<std::string>();
      if (uri.empty() || uri.rfind("data:", 0) == 0) continue;  // texture_problem's part
      const bool image = std::strcmp(key, "images") == 0;
      out.push_back({resolve(file, percent_decode(uri)),
                     std::string("glTF ") + (image ? "image " : "buffer ") + std::to_string(i),
                     image});
    }
  }
  // The textures photonflow reads (base colour, metallic-roughness) of every material.
  const auto mats = doc.find("materials");
  if (mats == doc.end() || !mats->is_array()) return;
  for (size_t i = 0; i < mats->size(); ++i) {
    const nlohmann::json& m = (*mats)[i];
    if (!m.is_object() || !m.contains("pbrMetallicRoughness")) continue;
    const nlohmann::json& pbr = m["pbrMetallicRoughness"];
    if (!pbr.is_object()) continue;
    const std::string name = m.contains("name") && m["name"].is_string()
                                 ? m["name"].get<std::string>()
                                 : "material" + std::to_string(i);
    for (const char* slot : {"baseColorTexture", "metallicRoughnessTexture"}) {
      if (!pbr.contains(slot)) continue;
      const std::string why = texture_problem(doc, pbr[slot]);
      if (why.empty()) continue;
      const std::string line = "material '" + shown(name) + "': " + slot + " " + why;
      if (!policy.missing_textures_warn)
        throw input_error(file, line, "fix the texture, or bake with --missing-textures warn to "
                                      "use the material's factors alone");
      warnings.push_back(file + ": " + line + "; using the material's factors alone");
    }
  }
}

// The first word after `keyword` on each line of an OBJ or MTL text that starts with it
// (mtllib takes the rest of the line: names with spaces; map_* take the last word, after options).
void keyword_files(const std::string& file, const std::string& text, const std::string& keyword,
                   bool last_word, const std::string& role, bool image,
                   std::vector<SceneReference>& out) {
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    size_t at = line.find_first_not_of(" \t");
    if (at == std::string::npos || line.compare(at, keyword.size(), keyword) != 0) continue;
    at += keyword.size();
    if (at >= line.size() || (line[at] != ' ' && line[at] != '\t')) continue;
    std::string rest = line.substr(at);
    const size_t b = rest.find_first_not_of(" \t"), e = rest.find_last_not_of(" \t");
    if (b == std::string::npos) continue;
    rest = rest.substr(b, e - b + 1);
    if (last_word) {
      const size_t sp = rest.find_last_of(" \t");
      if (sp != std::string::npos) rest = rest.substr(sp + 1);
    }
    out.push_back({resolve(file, rest), role, image});
  }
}

void obj_references(const std::string& file, const InputPolicy& policy, const std::string& root,
                    std::vector<SceneReference>& out) {
  std::vector<SceneReference> libs;
  keyword_files(file, read_text(file), "mtllib", false, "OBJ mtllib", false, libs);
  for (const SceneReference& lib : libs) {
    out.push_back(lib);
    // The material library's images, when it is there and a regular file (checked first).
    if (!check_input_file(lib.path, lib.role, file, policy, root)) continue;
    const std::string text = read_text(lib.path);
    for (const char* map : {"map_Kd", "map_d", "map_Ka", "map_Ks", "map_Ns", "map_Bump", "bump",
                            "map_Pr", "map_Pm", "map_Ke", "disp", "decal", "refl"})
      keyword_files(lib.path, text, map, true, std::string("MTL ") + map + " of " + lib.path,
                    true, out);
  }
}

void collada_references(const std::string& file, std::vector<SceneReference>& out) {
  const std::string text = read_text(file);
  size_t at = 0;
  while ((at = text.find("<init_from>", at)) != std::string::npos) {
    at += 11;
    const size_t end = text.find("</init_from>", at);
    if (end == std::string::npos) break;
    std::string ref = text.substr(at, end - at);
    const size_t b = ref.find_first_not_of(" \t\r\n"), e = ref.find_last_not_of(" \t\r\n");
    if (b == std::string::npos) continue;
    ref = ref.substr(b, e - b + 1);
    if (ref.rfind("file://", 0) == 0) ref = ref.substr(7);
    // <init_from> of a surface names an <image> id, not a file: only names with an image
    // extension are files.
    const std::string ext = lower_extension(ref);
    if (ext != ".png" && ext != ".jpg" && ext != ".jpeg" && ext != ".tga" && ext != ".bmp" &&
        ext != ".exr" && ext != ".tif" && ext != ".tiff")
      continue;
    out.push_back({resolve(file, percent_decode(ref)), "COLLADA image", true});
  }
}

const char* kind_of(mode_t m) {
  if (S_ISFIFO(m)) return "a FIFO (named pipe)";
  if (S_ISDIR(m)) return "a directory";
  if (S_ISCHR(m)) return "a character device";
  if (S_ISBLK(m)) return "a block device";
  if (S_ISSOCK(m)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string lower_extension(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

std::string input_root(const std::string& scene_file) {
  const std::string dir = folder_of(scene_file);
  std::error_code ec;
  const fs::path root = fs::canonical(dir.empty() ? "." : dir, ec);
  return ec ? fs::absolute(dir.empty() ? "." : dir).lexically_normal().string() : root.string();
}

bool outside_root(const std::string& path, const std::string& root) {
  std::error_code ec;
  fs::path real = fs::weakly_canonical(path, ec);
  if (ec) real = fs::absolute(path).lexically_normal();
  const std::string r = real.string();
  const std::string prefix = root.back() == '/' ? root : root + "/";
  return r.compare(0, prefix.size(), prefix) != 0;
}

bool check_input_file(const std::string& path, const std::string& role,
                      const std::string& scene_file, const InputPolicy& policy,
                      const std::string& root) {
  const std::string of = scene_file.empty() || scene_file == path ? "" : " of " + scene_file;
  if (policy.confine && outside_root(path, root))
    throw input_error(path, role + of + " lies outside the scene's folder " + root +
                                " (after symlinks), and --confine-inputs keeps a bake inside it",
                      "copy the file into the scene's folder, or bake without --confine-inputs");
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) {
    if (errno == ELOOP)
      throw input_error(path, role + of + " is a symlink loop", "give a file");
    if (errno == ENOENT || errno == ENOTDIR) return false;
    throw input_error(path, role + of + " cannot be examined: " + std::strerror(errno),
                      "check the path and its permissions");
  }
  if (!S_ISREG(st.st_mode))
    throw input_error(path, role + of + " is " + kind_of(st.st_mode) + ", not a regular file",
                      "give a file; a scene's buffers, images and material libraries are read "
                      "as files only");
  return true;
}

std::vector<SceneReference> scene_references(const std::string& scene_file,
                                             const InputPolicy& policy, const std::string& root,
                                             std::vector<std::string>& warnings) {
  std::vector<SceneReference> out;
  const std::string ext = lower_extension(scene_file);
  if (ext == ".gltf" || ext == ".glb") gltf_references(scene_file, policy, warnings, out);
  if (ext == ".obj") obj_references(scene_file, policy, root, out);
  if (ext == ".dae") collada_references(scene_file, out);
  return out;
}

void check_scene_inputs(const std::string& scene_file, const std::vector<std::string>& inserts,
                        const InputPolicy& policy, std::vector<std::string>& warnings) {
  const std::string root = input_root(scene_file);
  std::vector<std::string> files = {scene_file};
  files.insert(files.end(), inserts.begin(), inserts.end());
  for (size_t k = 0; k < files.size(); ++k) {
    const std::string& file = files[k];
    // The scene file itself needs no confinement (the user names it); inserts do.
    InputPolicy own = policy;
    own.confine = policy.confine && k > 0;
    if (!check_input_file(file, k == 0 ? "the scene file" : "inserted mesh", "", own, root))
      throw input_error(file, k == 0 ? "cannot read scene file" : "inserted mesh: no such file",
                        "check the path and its permissions");
    for (const SceneReference& ref : scene_references(file, policy, root, warnings)) {
      if (check_input_file(ref.path, ref.role, file, policy, root) || ref.image) continue;
      throw input_error(ref.path, ref.role + " of " + file + ": no such file",
                        "put the file beside the scene, or export the scene with it embedded");
    }
  }
}

std::vector<std::string> bake_input_files(const std::string& scene_file,
                                          const std::vector<std::string>& inserts,
                                          const std::string& environment,
                                          const std::string& options_file) {
  std::vector<std::string> out = {scene_file};
  if (!options_file.empty()) out.push_back(options_file);
  std::vector<std::string> files = {scene_file};
  files.insert(files.end(), inserts.begin(), inserts.end());
  const std::string root = input_root(scene_file);
  InputPolicy lenient;
  lenient.missing_textures_warn = true;  // the bake has applied its own policy already
  for (size_t k = 0; k < files.size(); ++k) {
    if (k > 0) out.push_back(files[k]);
    std::vector<std::string> ignored;
    for (const SceneReference& ref : scene_references(files[k], lenient, root, ignored)) {
      std::error_code ec;
      if (std::filesystem::is_regular_file(ref.path, ec)) out.push_back(ref.path);
    }
  }
  float rgb[3];
  if (!environment.empty() && !parse_environment_colour(environment, rgb))
    out.push_back(environment);
  return out;
}

}  // namespace pf
