#include "mpm/step/gmsh_api.hpp"

#include <dlfcn.h>
#include <gmshc.h>  // the C API's declarations; its functions are looked up, not linked

#include <memory>
#include <mutex>
#include <stdexcept>

#ifndef PFM_GMSH_LIBRARY
#error "PFM_GMSH_LIBRARY: the gmsh library file, set by mpm/step/CMakeLists.txt"
#endif

namespace pfm::gmsh {

namespace {

// The gmsh library, opened once: the library file found at configure time, else its name
// alone (the loader's search path).
void* library() {
  static void* handle = nullptr;
  static std::string error;
  static std::once_flag opened;
  std::call_once(opened, [] {
    const std::string path = PFM_GMSH_LIBRARY;
    handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle != nullptr) return;
    error = dlerror();
    const std::string name = path.substr(path.find_last_of('/') + 1);
    handle = dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle == nullptr) error += "; " + std::string(dlerror());
  });
  if (handle == nullptr) throw std::runtime_error("cannot load the gmsh library: " + error);
  return handle;
}

// The C API function `name`, of the type `F` of its declaration in gmshc.h.
template <class F>
F* function(const char* name) {
  void* symbol = dlsym(library(), name);
  if (symbol == nullptr) {
    throw std::runtime_error(std::string("the gmsh library has no function ") + name);
  }
  return reinterpret_cast<F*>(symbol);
}

// Looks up gmsh's C function `f` once, by its name (decltype: the declaration is not used, so
// nothing is linked).
#define PFM_GMSH(f)                                          \
  ([]() {                                                    \
    static auto* const resolved = function<decltype(f)>(#f); \
    return resolved;                                         \
  }())

// Throws when a call reported an error.
void check(int ierr, const char* what) {
  if (ierr != 0) {
    throw CallError(std::string("gmsh: ") + what + " failed (error " + std::to_string(ierr) + ")");
  }
}

// An array gmsh allocated, freed by gmsh.
template <class T>
struct Owned {
  T* data = nullptr;
  std::size_t n = 0;
  Owned() = default;
  Owned(const Owned&) = delete;
  Owned& operator=(const Owned&) = delete;
  ~Owned() {
    if (data != nullptr) PFM_GMSH(gmshFree)(data);  // only gmsh, loaded, set it
  }
  std::vector<T> vector() const { return std::vector<T>(data, data + n); }
};

// The (dimension, tag) pairs that `list` (gmshModelGetEntities or gmshModelGetPhysicalGroups)
// gives for dimension `dim` (-1: all), as a flat array.
template <class F>
vectorpair pairs_of(F* list, int dim, const char* what) {
  int ierr = 0;
  Owned<int> flat;
  list(&flat.data, &flat.n, dim, &ierr);
  check(ierr, what);
  vectorpair out;
  for (std::size_t k = 0; k + 1 < flat.n; k += 2) out.emplace_back(flat.data[k], flat.data[k + 1]);
  return out;
}

std::string text(char* owned) {
  if (owned == nullptr) return {};
  std::string out = owned;
  PFM_GMSH(gmshFree)(owned);
  return out;
}

}  // namespace

void initialize() {
  int ierr = 0;
  PFM_GMSH(gmshInitialize)(0, nullptr, 0, &ierr);
  check(ierr, "initialize");
}

void finalize() {
  int ierr = 0;
  PFM_GMSH(gmshFinalize)(&ierr);
  check(ierr, "finalize");
}

void open(const std::string& file_name) {
  int ierr = 0;
  PFM_GMSH(gmshOpen)(file_name.c_str(), &ierr);
  check(ierr, "open");
}

namespace option {
void setNumber(const std::string& name, double value) {
  int ierr = 0;
  PFM_GMSH(gmshOptionSetNumber)(name.c_str(), value, &ierr);
  check(ierr, "option::setNumber");
}
}  // namespace option

namespace model {

void add(const std::string& name) {
  int ierr = 0;
  PFM_GMSH(gmshModelAdd)(name.c_str(), &ierr);
  check(ierr, "model::add");
}

void getEntities(vectorpair& dim_tags, int dim) {
  dim_tags = pairs_of(PFM_GMSH(gmshModelGetEntities), dim, "model::getEntities");
}

void getPhysicalGroups(vectorpair& dim_tags, int dim) {
  dim_tags = pairs_of(PFM_GMSH(gmshModelGetPhysicalGroups), dim, "model::getPhysicalGroups");
}

void getPhysicalName(int dim, int tag, std::string& name) {
  int ierr = 0;
  char* owned = nullptr;
  PFM_GMSH(gmshModelGetPhysicalName)(dim, tag, &owned, &ierr);
  name = text(owned);
  check(ierr, "model::getPhysicalName");
}

void getEntitiesForPhysicalGroup(int dim, int tag, std::vector<int>& tags) {
  int ierr = 0;
  Owned<int> owned;
  PFM_GMSH(gmshModelGetEntitiesForPhysicalGroup)(dim, tag, &owned.data, &owned.n, &ierr);
  check(ierr, "model::getEntitiesForPhysicalGroup");
  tags = owned.vector();
}

namespace mesh {

void generate(int dim) {
  int ierr = 0;
  PFM_GMSH(gmshModelMeshGenerate)(dim, &ierr);
  check(ierr, "model::mesh::generate");
}

std::string elementName(int element_type) {
  int ierr = 0, dim = 0, order = 0, n_nodes = 0, n_primary = 0;
  char* name = nullptr;
  Owned<double> local;
  PFM_GMSH(gmshModelMeshGetElementProperties)
  (element_type, &name, &dim, &order, &n_nodes, &local.data, &local.n, &n_primary, &ierr);
  std::string out = text(name);
  check(ierr, "model::mesh::getElementProperties");
  return out;
}

std::array<double, 3> getNode(std::size_t node_tag) {
  int ierr = 0;
  Owned<double> coord, parametric;
  PFM_GMSH(gmshModelMeshGetNode)
  (node_tag, &coord.data, &coord.n, &parametric.data, &parametric.n, &ierr);
  check(ierr, "model::mesh::getNode");
  if (coord.n != 3) throw CallError("gmsh: model::mesh::getNode gave no x, y, z");
  return {coord.data[0], coord.data[1], coord.data[2]};
}

void getNodes(std::vector<std::size_t>& node_tags, std::vector<double>& coord) {
  int ierr = 0;
  Owned<std::size_t> tags;
  Owned<double> xyz, parametric;
  PFM_GMSH(gmshModelMeshGetNodes)
  (&tags.data, &tags.n, &xyz.data, &xyz.n, &parametric.data, &parametric.n, -1, -1, 0, 0, &ierr);
  check(ierr, "model::mesh::getNodes");
  node_tags = tags.vector();
  coord = xyz.vector();
}

void getElements(std::vector<int>& types, std::vector<std::vector<std::size_t>>& element_tags,
                 std::vector<std::vector<std::size_t>>& node_tags, int dim, int tag) {
  int ierr = 0;
  Owned<int> owned_types;
  std::size_t** elements = nullptr;
  std::size_t* elements_n = nullptr;
  std::size_t elements_nn = 0;
  std::size_t** nodes = nullptr;
  std::size_t* nodes_n = nullptr;
  std::size_t nodes_nn = 0;
  PFM_GMSH(gmshModelMeshGetElements)
  (&owned_types.data, &owned_types.n, &elements, &elements_n, &elements_nn, &nodes, &nodes_n,
   &nodes_nn, dim, tag, &ierr);
  const auto gmsh_free = PFM_GMSH(gmshFree);
  const auto take = [&](std::size_t** arrays, const std::size_t* sizes, std::size_t count) {
    std::vector<std::vector<std::size_t>> out;
    for (std::size_t k = 0; k < count; ++k) {
      out.emplace_back(arrays[k], arrays[k] + sizes[k]);
      gmsh_free(arrays[k]);
    }
    gmsh_free(arrays);
    gmsh_free(const_cast<std::size_t*>(sizes));
    return out;
  };
  element_tags = take(elements, elements_n, elements_nn);
  node_tags = take(nodes, nodes_n, nodes_nn);
  check(ierr, "model::mesh::getElements");
  types = owned_types.vector();
}

void getElementsByType(int element_type, std::vector<std::size_t>& element_tags,
                       std::vector<std::size_t>& node_tags) {
  int ierr = 0;
  Owned<std::size_t> elements, nodes;
  PFM_GMSH(gmshModelMeshGetElementsByType)
  (element_type, &elements.data, &elements.n, &nodes.data, &nodes.n, -1, 0, 1, &ierr);
  check(ierr, "model::mesh::getElementsByType");
  element_tags = elements.vector();
  node_tags = nodes.vector();
}

}  // namespace mesh

namespace geo {

int addPoint(double x, double y, double z, double mesh_size) {
  int ierr = 0;
  const int tag = PFM_GMSH(gmshModelGeoAddPoint)(x, y, z, mesh_size, -1, &ierr);
  check(ierr, "model::geo::addPoint");
  return tag;
}

int addLine(int start_tag, int end_tag) {
  int ierr = 0;
  const int tag = PFM_GMSH(gmshModelGeoAddLine)(start_tag, end_tag, -1, &ierr);
  check(ierr, "model::geo::addLine");
  return tag;
}

int addCurveLoop(const std::vector<int>& curve_tags) {
  int ierr = 0;
  std::vector<int> tags = curve_tags;  // the C API takes a non-const pointer
  const int tag = PFM_GMSH(gmshModelGeoAddCurveLoop)(tags.data(), tags.size(), -1, 0, &ierr);
  check(ierr, "model::geo::addCurveLoop");
  return tag;
}

int addPlaneSurface(const std::vector<int>& wire_tags) {
  int ierr = 0;
  std::vector<int> tags = wire_tags;
  const int tag = PFM_GMSH(gmshModelGeoAddPlaneSurface)(tags.data(), tags.size(), -1, &ierr);
  check(ierr, "model::geo::addPlaneSurface");
  return tag;
}

void synchronize() {
  int ierr = 0;
  PFM_GMSH(gmshModelGeoSynchronize)(&ierr);
  check(ierr, "model::geo::synchronize");
}

namespace mesh {

void setTransfiniteCurve(int tag, int n_points) {
  int ierr = 0;
  PFM_GMSH(gmshModelGeoMeshSetTransfiniteCurve)(tag, n_points, "Progression", 1.0, &ierr);
  check(ierr, "model::geo::mesh::setTransfiniteCurve");
}

void setTransfiniteSurface(int tag, const std::string& arrangement,
                           const std::vector<int>& corner_tags) {
  int ierr = 0;
  std::vector<int> corners = corner_tags;
  PFM_GMSH(gmshModelGeoMeshSetTransfiniteSurface)
  (tag, arrangement.c_str(), corners.data(), corners.size(), &ierr);
  check(ierr, "model::geo::mesh::setTransfiniteSurface");
}

void setRecombine(int dim, int tag) {
  int ierr = 0;
  PFM_GMSH(gmshModelGeoMeshSetRecombine)(dim, tag, 45.0, &ierr);
  check(ierr, "model::geo::mesh::setRecombine");
}

}  // namespace mesh
}  // namespace geo
}  // namespace model

}  // namespace pfm::gmsh
