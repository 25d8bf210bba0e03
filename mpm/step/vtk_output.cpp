#include "mpm/step/vtk_output.hpp"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "mpm/step/output.hpp"

namespace pfm {

namespace {

// The files say byte_order="LittleEndian" and hold the arrays' bytes as they are in memory.
static_assert(std::endian::native == std::endian::little, "VTK output assumes little-endian");

std::string base64(const unsigned char* data, std::size_t size) {
  static const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve(4 * ((size + 2) / 3));
  for (std::size_t k = 0; k < size; k += 3) {
    const std::uint32_t a = data[k];
    const std::uint32_t b = k + 1 < size ? data[k + 1] : 0u;
    const std::uint32_t c = k + 2 < size ? data[k + 2] : 0u;
    const std::uint32_t triple = (a << 16) | (b << 8) | c;
    out.push_back(alphabet[(triple >> 18) & 63]);
    out.push_back(alphabet[(triple >> 12) & 63]);
    out.push_back(k + 1 < size ? alphabet[(triple >> 6) & 63] : '=');
    out.push_back(k + 2 < size ? alphabet[triple & 63] : '=');
  }
  return out;
}

// One DataArray's payload in VTK's compressed binary encoding: the header (number of blocks,
// block size, last block's size, each block's compressed size; UInt64) in base64, then the
// compressed blocks in base64.
constexpr std::size_t kBlock = 1 << 16;

template <class T>
std::string encoded(const std::vector<T>& values) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(values.data());
  const std::size_t size = values.size() * sizeof(T);
  const std::size_t blocks = size == 0 ? 0 : (size + kBlock - 1) / kBlock;
  std::vector<std::uint64_t> header = {blocks, kBlock,
                                       blocks == 0 ? 0 : size - (blocks - 1) * kBlock};
  std::vector<unsigned char> compressed;
  for (std::size_t b = 0; b < blocks; ++b) {
    const std::size_t length = std::min(kBlock, size - b * kBlock);
    uLongf room = compressBound(static_cast<uLong>(length));
    std::vector<unsigned char> block(room);
    if (compress2(block.data(), &room, bytes + b * kBlock, static_cast<uLong>(length), 6) != Z_OK)
      throw std::runtime_error("zlib could not compress a VTK data block");
    header.push_back(room);
    compressed.insert(compressed.end(), block.begin(), block.begin() + static_cast<long>(room));
  }
  return base64(reinterpret_cast<const unsigned char*>(header.data()),
                header.size() * sizeof(std::uint64_t)) +
         base64(compressed.data(), compressed.size());
}

template <class T>
void data_array(std::ostringstream& out, const char* type, const char* name, int components,
                const std::vector<T>& values) {
  out << "<DataArray type=\"" << type << "\" Name=\"" << name << "\"";
  if (components > 1) out << " NumberOfComponents=\"" << components << "\"";
  out << " format=\"binary\">" << encoded(values) << "</DataArray>\n";
}

// The .vtu document: points (x, y, 0), their data (DataArray elements), and cells of one type
// given by their nodes' connectivity and end offsets.
std::string vtu_document(const std::vector<double>& points, std::size_t n_points,
                         const std::string& point_data,
                         const std::vector<std::int64_t>& connectivity,
                         const std::vector<std::int64_t>& offsets, std::uint8_t cell_type) {
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n"
      << "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" "
         "header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">\n"
      << "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" << n_points << "\" NumberOfCells=\""
      << offsets.size() << "\">\n<PointData>\n"
      << point_data << "</PointData>\n<Points>\n";
  data_array(out, "Float64", "position", 3, points);
  out << "</Points>\n<Cells>\n";
  data_array(out, "Int64", "connectivity", 1, connectivity);
  data_array(out, "Int64", "offsets", 1, offsets);
  data_array(out, "UInt8", "types", 1, std::vector<std::uint8_t>(offsets.size(), cell_type));
  out << "</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n";
  return out.str();
}

// VTK cell types
constexpr std::uint8_t kVtkVertex = 1, kVtkLine = 3;

}  // namespace

std::string particles_vtu(const Particles& particles, std::span<const Stress> recovered) {
  const std::size_t n = particles.size();
  std::ostringstream out;
  std::vector<double> v3(3 * n, 0.0), v1(n);
  auto vec3 = [&](auto get) {
    for (std::size_t p = 0; p < n; ++p) {
      const Vec2 v = get(p);
      v3[3 * p] = v.x();
      v3[3 * p + 1] = v.y();
    }
  };
  vec3(
      [&](std::size_t p) { return Vec2(particles.position[p] - particles.reference_position[p]); });
  data_array(out, "Float64", "displacement", 3, v3);
  vec3([&](std::size_t p) { return particles.velocity[p]; });
  data_array(out, "Float64", "velocity", 3, v3);
  const char* stress_names[4] = {"sxx", "syy", "sxy", "szz"};
  for (int k = 0; k < 4; ++k) {
    for (std::size_t p = 0; p < n; ++p) v1[p] = particles.stress[p][k];
    data_array(out, "Float64", stress_names[k], 1, v1);
  }
  for (std::size_t p = 0; p < n; ++p) v1[p] = particles.state[p].plastic_strain;
  data_array(out, "Float64", "eps_p", 1, v1);
  for (std::size_t p = 0; p < n; ++p) v1[p] = particles.volume[p];
  data_array(out, "Float64", "volume", 1, v1);
  std::vector<std::int64_t> id(n);
  for (std::size_t p = 0; p < n; ++p) id[p] = static_cast<std::int64_t>(p);
  data_array(out, "Int64", "id", 1, id);
  std::vector<std::int32_t> index(particles.material.begin(), particles.material.end());
  data_array(out, "Int32", "material", 1, index);
  index.assign(particles.body.begin(), particles.body.end());
  data_array(out, "Int32", "body", 1, index);
  const char* gradient_names[4] = {"F11", "F12", "F21", "F22"};
  for (int k = 0; k < 4; ++k) {
    for (std::size_t p = 0; p < n; ++p) v1[p] = particles.deformation_gradient[p](k / 2, k % 2);
    data_array(out, "Float64", gradient_names[k], 1, v1);
  }
  for (int k = 0; k < 4; ++k) {
    for (std::size_t p = 0; p < n; ++p) v1[p] = recovered_or_own(recovered, particles, p)[k];
    data_array(out, "Float64", kRecoveredStressNames[k], 1, v1);
  }
  // One vertex cell per point.
  std::vector<std::int64_t> offsets(n);
  for (std::size_t p = 0; p < n; ++p) offsets[p] = static_cast<std::int64_t>(p + 1);
  vec3([&](std::size_t p) { return particles.position[p]; });
  return vtu_document(v3, n, out.str(), id, offsets, kVtkVertex);
}

std::string boundary_vtu(const std::vector<std::vector<Vec2>>& loops,
                         const std::vector<bool>& closed) {
  std::vector<double> points;
  std::vector<std::int32_t> loop;
  std::vector<std::int64_t> connectivity, offsets;
  for (std::size_t k = 0; k < loops.size(); ++k) {
    const auto first = static_cast<std::int64_t>(loop.size());
    const auto count = static_cast<std::int64_t>(loops[k].size());
    for (const Vec2& x : loops[k]) {
      points.insert(points.end(), {x.x(), x.y(), 0.0});
      loop.push_back(static_cast<std::int32_t>(k));
    }
    // A 2-node line per segment; a closed loop's last one back to its first point.
    const std::int64_t segments = closed[k] && count > 2 ? count : count - 1;
    for (std::int64_t i = 0; i < segments; ++i) {
      connectivity.insert(connectivity.end(), {first + i, first + (i + 1) % count});
      offsets.push_back(static_cast<std::int64_t>(connectivity.size()));
    }
  }
  std::ostringstream data;
  data_array(data, "Int32", "loop", 1, loop);
  return vtu_document(points, loop.size(), data.str(), connectivity, offsets, kVtkLine);
}

VtkSeriesWriter::VtkSeriesWriter(OutputFolder& folder, std::string name)
    : folder_(folder), name_(std::move(name)) {}

VtkSeriesWriter::VtkSeriesWriter(OutputFolder& folder, std::string name,
                                 const std::vector<std::pair<double, long>>& keep)
    : folder_(folder), name_(std::move(name)) {
  for (const auto& [time, step] : keep) files_.emplace_back(time, file_name(step));
  write_pvd();
}

std::string VtkSeriesWriter::file_name(long step) const {
  char digits[24];
  std::snprintf(digits, sizeof digits, "_%08ld.vtu", step);
  return name_ + digits;
}

void VtkSeriesWriter::write(double time, long step, const std::string& vtu) {
  const std::string name = file_name(step);
  write_file_atomically(folder_.file(name), vtu);
  files_.emplace_back(time, name);
  write_pvd();
}

void VtkSeriesWriter::write_pvd() const {
  std::ostringstream out;
  out << "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\">\n"
      << "<Collection>\n";
  for (const auto& [time, name] : files_)
    out << "<DataSet timestep=\"" << format_exact(time) << "\" file=\"" << name << "\"/>\n";
  out << "</Collection>\n</VTKFile>\n";
  write_file_atomically(folder_.file(name_ + ".pvd"), out.str());
}

}  // namespace pfm
