// The assimp read of one scene file (read_file, scene_import_internal.h): its post-processing,
// the address-space budget of the import, and one-line InputErrors for what assimp cannot read.
//
// Reading. Post-processing is aiProcess_Triangulate | aiProcess_ValidateDataStructure only:
//   - no aiProcess_GenNormals/GenSmoothNormals: shading normals are the file's own, or the
//     geometric normal when the file has none;
//   - no aiProcess_JoinIdenticalVertices: the output is a triangle soup, so joining changes
//     nothing in the result, and it is not safe on bad input — it merges a vertex with a NaN
//     coordinate into a finite one, which hides the error this stage must report;
//   - no aiProcess_PreTransformVertices: the node graph is flattened here, keeping one mesh id per
//     mesh instance (node × mesh), which the per-mesh photon sorting of thesis ch. 7.3 needs.
// Face indices are checked again by the flattener (ValidateDataStructure runs only when the
// loader succeeds).
// Each import runs under an address-space cap (memory_cap.h): 256 MiB + 64 × the bytes of the files
// assimp opens (BudgetIOSystem counts them, glTF buffers and OBJ material libraries included), or
// BakeOptions::import_memory_mb; a parser that runs away on a damaged file is refused promptly.
#include <assimp/DefaultIOSystem.h>
#include <assimp/IOStream.hpp>
#include <assimp/postprocess.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <memory>
#include <new>
#include <set>
#include <string>

#include "photonflow/foundations/error.h"
#include "photonflow/foundations/memory_cap.h"
#include "photonflow/geometry/scene_import_internal.h"
#include "photonflow/geometry/scene_inputs.h"

namespace pf::import {

namespace {

// Automatic import budget (memory_cap.h): a floor for the importer's own state plus a multiple of
// the bytes assimp reads. Measured (--import-memory-mb, smallest power of two that bakes): the
// 3.7 MB ogre.obj imports in 64 MiB, the 2.4 MB stanford-bunny.obj in 32 MiB, 9–17 × their size.
constexpr uint64_t kImportBudgetFloor = uint64_t(256) << 20;
constexpr uint64_t kImportBudgetPerByte = 64;

// assimp's file system, counting each file it opens once into the import's address-space budget.
class BudgetIOSystem : public Assimp::DefaultIOSystem {
 public:
  BudgetIOSystem(AddressSpaceCap& cap, uint64_t per_byte) : cap_(cap), per_byte_(per_byte) {}
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    // A FIFO or a directory (an OBJ's mtllib naming one) is not opened: its read would block.
    struct stat st {};
    if (stat(file, &st) == 0 && !S_ISREG(st.st_mode)) return nullptr;
    Assimp::IOStream* stream = Assimp::DefaultIOSystem::Open(file, mode);
    if (stream && per_byte_ > 0 && opened_.insert(file).second) {
      bytes_ += stream->FileSize();
      cap_.grow(per_byte_ * uint64_t(stream->FileSize()));
    }
    return stream;
  }
  uint64_t bytes() const { return bytes_; }

 private:
  AddressSpaceCap& cap_;
  uint64_t per_byte_;
  std::set<std::string> opened_;
  uint64_t bytes_ = 0;
};

std::string mib(uint64_t bytes) { return std::to_string((bytes + (1u << 20) - 1) >> 20) + " MiB"; }

// The first file `path` references outside its own folder ("" for none, or when the references
// cannot be read).
std::string reference_outside_folder(const std::string& path) {
  try {
    std::vector<std::string> ignored;
    const std::string root = input_root(path);
    for (const SceneReference& ref : scene_references(path, InputPolicy{}, root, ignored))
      if (outside_root(ref.path, root)) return ref.path;
  } catch (const std::exception&) {
  }
  return {};
}

}  // namespace

std::string one_line(std::string s) {
  std::replace(s.begin(), s.end(), '\n', ' ');
  std::replace(s.begin(), s.end(), '\r', ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

const aiScene* read_file(Assimp::Importer& importer, const std::string& path,
                         const ImportContext& ctx) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode) || access(path.c_str(), R_OK) != 0)
    throw input_error(path, "cannot read scene file", "check the path and its permissions");
  if (ctx.reading) ctx.reading(path);
  const uint64_t memory_mb = ctx.memory_mb;
  const aiScene* ai = nullptr;
  bool threw = false, out_of_memory = false, capped = false;
  uint64_t budget = 0, bytes = 0;
  {
    AddressSpaceCap cap(memory_mb > 0 ? memory_mb << 20 : kImportBudgetFloor);
    auto io = std::make_unique<BudgetIOSystem>(cap, memory_mb > 0 ? 0 : kImportBudgetPerByte);
    importer.SetIOHandler(io.get());
    // Back to assimp's default handler before `io` goes, however this block is left (the
    // importer hands a handler back to its caller when given nullptr).
    struct Restore {
      Assimp::Importer& importer;
      ~Restore() { importer.SetIOHandler(nullptr); }
    } restore{importer};
    try {
      ai = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_ValidateDataStructure);
    } catch (const std::bad_alloc&) {  // loaders that do not catch it themselves
      threw = true;
    }
    capped = cap.active();
    budget = cap.budget();
    bytes = io->bytes();
    // assimp's BaseImporter catches the loader's exceptions and keeps their what() as its error.
    out_of_memory = threw || (!ai && std::string(importer.GetErrorString()) == "std::bad_alloc");
  }
  if (out_of_memory && !capped)
    throw input_error(path, "assimp ran out of memory reading it",
                      "check the file; an assimp loader runs away on some damaged files");
  if (out_of_memory) {
    const std::string limit =
        memory_mb > 0 ? "--import-memory-mb " + std::to_string(memory_mb)
                      : mib(kImportBudgetFloor) + " + " + std::to_string(kImportBudgetPerByte) +
                            " x the " + std::to_string(bytes) + " bytes of its files";
    throw input_error(path, "assimp needed more than the import's " + mib(budget) +
                                " of address space reading it (" + limit +
                                "); an assimp loader runs away on some damaged files",
                      "check the file; if it is whole, raise --import-memory-mb");
  }
  if (!ai) {
    const std::string ext = lower_extension(path);
    if (ext.empty() || !importer.IsExtensionSupported(ext))
      throw input_error(path, "not a scene format assimp reads",
                        "use COLLADA (.dae), Wavefront OBJ, glTF or PLY");
    // assimp's message may quote a referenced file's size or bytes: for a file outside the
    // scene's folder (/etc/passwd as a buffer) it is not shown.
    if (const std::string away = reference_outside_folder(path); !away.empty())
      throw input_error(path, "assimp cannot read it (its message is not shown: the scene "
                              "references " + away + ", outside its folder)",
                        "check that the file is valid " + ext.substr(1));
    throw input_error(path, "assimp cannot read it: " + one_line(importer.GetErrorString()),
                      "check that the file is valid " + ext.substr(1));
  }
  if (!ai->mRootNode)
    throw input_error(path, "has no scene graph", "export it again with its geometry");
  return ai;
}

}  // namespace pf::import
