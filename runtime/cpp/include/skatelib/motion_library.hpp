// skatelib motion-library reader for C++ controllers: header-only, on the HDF5 C API and nlohmann/json.
//
// Reads the format described in docs/library-format.md (major version 1): the packed arrays under
// /packed and the JSON index /packed/index. Sampling has the semantics of skatelib.runtime:
// states linear between knots, controls and contact codes held (control k acts on [t_k, t_k+1)),
// times clamped to the entry. The arithmetic follows the Python runtime operation by operation,
// so both give the same numbers.
//
//   auto lib = skatelib::MotionLibrary::open("out/cyberdog2-default.h5");
//   const skatelib::Entry& e = lib.select(0.5, 2);
//   skatelib::Sample s = e.sample(0.613);          // s.state (28), s.control (24), s.contact (4)
//   skatelib::Window w = e.window(0.6, 10, 1.0 / 30);
//   e.sample_into(0.613, state_buf, control_buf, contact_buf);   // no allocation, for a 500 Hz loop
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace skatelib {

constexpr int kFormatMajor = 1;

// A file that is not a readable skatelib library of a supported version; names the file and field.
class FormatError : public std::runtime_error {
 public:
  FormatError(const std::string& path, const std::string& field, const std::string& what)
      : std::runtime_error(path + ": " + field + ": " + what), path(path), field(field) {}
  std::string path, field;
};

struct Sample {
  std::vector<double> state, control;
  std::vector<int8_t> contact;  // empty when the entry has no contact plan (humanoid)
};

struct Window {
  int n = 0;
  std::vector<double> t, state, control;  // row-major (n x nx), (n x nu)
  std::vector<int8_t> contact;            // (n x 4), empty without a contact plan
};

class Entry {
 public:
  std::string key;
  double target_velocity_mps = 0.0;
  double from_velocity_mps = 0.0;  // format 1.4: a transition's start speed; 0 for a start-up from rest
  int n_strides = 0;
  bool success = false;
  std::string status;
  int nx = 0, nu = 0, nc = 0, K = 0;
  std::vector<double> t, state, control;  // (K), (K x nx), (K-1 x nu) row-major
  std::vector<int8_t> contact;            // (K x nc)
  std::vector<std::string> state_columns, control_columns;

  // Precompute slopes and the uniform-grid factors (done by MotionLibrary::open).
  void prepare() {
    last_ = std::max(K - 2, 0);
    slope_.assign(state.size(), 0.0);
    for (int k = 0; k + 1 < K; ++k)
      for (int j = 0; j < nx; ++j) slope_[k * nx + j] = state[(k + 1) * nx + j] - state[k * nx + j];
    uniform_ = K > 1;
    if (K > 1) {
      const double dt0 = t[1] - t[0];
      for (int k = 0; k + 1 < K; ++k) {  // numpy.allclose(dt, dt[0], rtol=1e-9, atol=1e-12)
        const double d = t[k + 1] - t[k];
        if (std::fabs(d - dt0) > 1e-12 + 1e-9 * std::fabs(dt0)) uniform_ = false;
      }
      inv_dt_ = 1.0 / dt0;
    }
  }

  // Interval index i <= K-2 and fraction a in [0, 1] of time tt, clamped to the entry.
  std::pair<int, double> locate(double tt) const {
    if (tt <= t.front() || K < 2) return {0, 0.0};
    if (tt >= t.back()) return {last_, 1.0};
    if (uniform_) {
      const double u = (tt - t.front()) * inv_dt_;
      const int i = static_cast<int>(u);
      return i <= last_ ? std::make_pair(i, u - i) : std::make_pair(last_, 1.0);
    }
    const int i = std::min(static_cast<int>(std::upper_bound(t.begin(), t.end(), tt) - t.begin()) - 1, last_);
    return {i, (tt - t[i]) / (t[i + 1] - t[i])};
  }

  // Allocation-free sample: state_out (nx), control_out (nu), contact_out (nc, may be null).
  void sample_into(double tt, double* state_out, double* control_out, int8_t* contact_out) const {
    if (!std::isfinite(tt)) throw std::invalid_argument("sample(t): t must be a finite time in seconds");
    const auto [i, a] = locate(tt);
    const double* x = &state[i * nx];
    const double* d = &slope_[i * nx];
    for (int j = 0; j < nx; ++j) state_out[j] = x[j] + a * d[j];
    const int iu = control.empty() ? -1 : std::min(i, K - 2);
    for (int j = 0; j < nu; ++j) control_out[j] = iu >= 0 ? control[iu * nu + j] : 0.0;
    if (contact_out != nullptr && nc > 0) {
      const int ic = a >= 1.0 ? i + 1 : i;
      for (int j = 0; j < nc; ++j) contact_out[j] = contact[ic * nc + j];
    }
  }

  Sample sample(double tt) const {
    Sample s;
    s.state.resize(nx);
    s.control.resize(nu);
    s.contact.resize(nc);
    sample_into(tt, s.state.data(), s.control.data(), nc ? s.contact.data() : nullptr);
    return s;
  }

  // References at t0 + k dt, k = 0..n-1 (the same arithmetic as skatelib.runtime's window()).
  Window window(double t0, int n, double dt) const {
    if (!std::isfinite(t0)) throw std::invalid_argument("window(t0, n, dt): t0 must be a finite time in seconds");
    if (!(std::isfinite(dt) && dt > 0.0))
      throw std::invalid_argument("window(t0, n, dt): dt must be a positive, finite step in seconds");
    if (n < 1) throw std::invalid_argument("window(t0, n, dt): n must be at least 1");
    Window w;
    w.n = n;
    w.t.resize(n);
    w.state.resize(static_cast<size_t>(n) * nx);
    w.control.resize(static_cast<size_t>(n) * nu);
    if (nc) w.contact.resize(static_cast<size_t>(n) * nc);
    for (int k = 0; k < n; ++k) {
      double u;
      if (uniform_ && K >= 2) {
        u = static_cast<double>(k) * (dt * inv_dt_);
        u += (t0 - t.front()) * inv_dt_;
        u = std::clamp(u, 0.0, K - 1.0);
      } else {
        const double tc = std::clamp(t0 + dt * static_cast<double>(k), t.front(), t.back());
        int j = static_cast<int>(std::upper_bound(t.begin(), t.end(), tc) - t.begin()) - 1;
        j = std::clamp(j, 0, last_);
        const double span = K >= 2 ? t[j + 1] - t[j] : 1.0;
        u = j + (tc - t[j]) / span;
      }
      const int raw = static_cast<int>(u);
      const int i = std::min(raw, last_);
      const double a = u - i;
      for (int j = 0; j < nx; ++j) w.state[k * nx + j] = state[i * nx + j] + slope_[i * nx + j] * a;
      for (int j = 0; j < nu; ++j) w.control[k * nu + j] = control.empty() ? 0.0 : control[i * nu + j];
      for (int j = 0; j < nc; ++j) w.contact[k * nc + j] = contact[raw * nc + j];
      w.t[k] = t0 + dt * static_cast<double>(k);
    }
    return w;
  }

  double duration_s() const { return K ? t.back() - t.front() : 0.0; }

 private:
  std::vector<double> slope_;
  int last_ = 0;
  bool uniform_ = false;
  double inv_dt_ = 0.0;
};

namespace detail {

struct H5Handle {  // closes an HDF5 identifier with the right function
  hid_t id;
  herr_t (*close)(hid_t);
  ~H5Handle() {
    if (id >= 0) close(id);
  }
};

inline std::string read_string_attribute(hid_t file, const std::string& path, const char* name) {
  if (H5Aexists(file, name) <= 0) throw FormatError(path, std::string("/@") + name, "missing");
  H5Handle attr{H5Aopen(file, name, H5P_DEFAULT), H5Aclose};
  H5Handle type{H5Tcopy(H5T_C_S1), H5Tclose};
  H5Tset_size(type.id, H5T_VARIABLE);
  H5Tset_cset(type.id, H5T_CSET_UTF8);
  char* value = nullptr;
  if (attr.id < 0 || H5Aread(attr.id, type.id, &value) < 0 || value == nullptr)
    throw FormatError(path, std::string("/@") + name, "not a string");
  std::string out(value);
  H5free_memory(value);
  return out;
}

template <typename T>
std::vector<T> read_dataset(hid_t file, const std::string& path, const std::string& name, hid_t memtype,
                            std::vector<hsize_t>* dims_out = nullptr) {
  if (H5Lexists(file, name.c_str(), H5P_DEFAULT) <= 0) throw FormatError(path, name, "missing dataset");
  H5Handle ds{H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose};
  H5Handle space{H5Dget_space(ds.id), H5Sclose};
  const int rank = H5Sget_simple_extent_ndims(space.id);
  std::vector<hsize_t> dims(std::max(rank, 0));
  H5Sget_simple_extent_dims(space.id, dims.data(), nullptr);
  size_t count = 1;
  for (hsize_t d : dims) count *= d;
  std::vector<T> out(count);
  if (count && H5Dread(ds.id, memtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0)
    throw FormatError(path, name, "cannot be read (damaged file?)");
  if (dims_out) *dims_out = dims;
  return out;
}

template <typename T>
std::vector<T> rows(const std::vector<T>& packed, const nlohmann::json& range, size_t width) {
  const size_t a = range.at(0).get<size_t>(), b = range.at(1).get<size_t>();
  return std::vector<T>(packed.begin() + a * width, packed.begin() + b * width);
}

}  // namespace detail

class MotionLibrary {
 public:
  std::string path, kind, format_version;
  std::vector<Entry> entries;  // file order

  // Open, check the format and its major version, read the packed arrays and the index.
  static MotionLibrary open(const std::string& path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions, not stderr noise
    detail::H5Handle file{H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose};
    if (file.id < 0) throw FormatError(path, "-", "cannot open as HDF5 (missing, truncated or not a library)");
    MotionLibrary lib;
    lib.path = path;
    if (detail::read_string_attribute(file.id, path, "format") != "skatelib.motion-library")
      throw FormatError(path, "/@format", "not a skatelib motion library");
    lib.format_version = detail::read_string_attribute(file.id, path, "format_version");
    const int major = std::atoi(lib.format_version.c_str());
    if (major != kFormatMajor)
      throw FormatError(path, "/@format_version",
                        "version " + lib.format_version + " is not readable by this reader (major 1): " +
                            (major > kFormatMajor ? "update skatelib" : "rebuild the library with skatelib build"));
    lib.kind = detail::read_string_attribute(file.id, path, "kind");
    const auto raw = detail::read_dataset<uint8_t>(file.id, path, "/packed/index", H5T_NATIVE_UINT8);
    nlohmann::json index;
    try {
      index = nlohmann::json::parse(raw.begin(), raw.end());
    } catch (const nlohmann::json::exception& e) {
      throw FormatError(path, "/packed/index", std::string("not valid JSON: ") + e.what());
    }
    std::map<std::string, std::vector<hsize_t>> dims;
    auto packed_f64 = [&](const std::string& name) {
      return detail::read_dataset<double>(file.id, path, "/packed/" + name, H5T_NATIVE_DOUBLE, &dims[name]);
    };
    const auto t = packed_f64("t"), state = packed_f64("state"), control = packed_f64("control");
    std::vector<int8_t> contact;
    const bool has_contact = H5Lexists(file.id, "/packed/contact", H5P_DEFAULT) > 0;
    if (has_contact)
      contact = detail::read_dataset<int8_t>(file.id, path, "/packed/contact", H5T_NATIVE_INT8, &dims["contact"]);
    const size_t nx = dims["state"].at(1), nu = dims["control"].size() > 1 ? dims["control"][1] : 0;
    const size_t nc = has_contact ? dims["contact"].at(1) : 0;
    try {
      for (const auto& je : index.at("entries")) {
        Entry e;
        e.key = je.at("key").get<std::string>();
        const auto& at = je.at("attrs");
        e.target_velocity_mps = at.at("target_velocity_mps").get<double>();
        e.n_strides = at.at("n_strides").get<int>();
        e.from_velocity_mps = at.value("from_velocity_mps", 0.0);
        e.success = at.at("success").get<bool>();
        e.status = at.at("status").get<std::string>();
        const auto& r = je.at("rows");
        e.t = detail::rows(t, r.at("t"), 1);
        e.state = detail::rows(state, r.at("state"), nx);
        e.control = detail::rows(control, r.at("control"), nu);
        if (has_contact && r.contains("contact")) e.contact = detail::rows(contact, r.at("contact"), nc);
        e.nx = static_cast<int>(nx);
        e.nu = static_cast<int>(nu);
        e.nc = e.contact.empty() ? 0 : static_cast<int>(nc);
        e.K = static_cast<int>(e.t.size());
        e.state_columns = je.at("columns").at("state").get<std::vector<std::string>>();
        e.control_columns = je.at("columns").at("control").get<std::vector<std::string>>();
        e.prepare();
        lib.entries.push_back(std::move(e));
      }
    } catch (const nlohmann::json::exception& e) {
      throw FormatError(path, "/packed/index", std::string("incomplete entry record: ") + e.what());
    }
    return lib;
  }

  const Entry& at(const std::string& key) const {
    for (const auto& e : entries)
      if (e.key == key) return e;
    throw std::out_of_range(path + ": no entry '" + key + "'");
  }

  bool contains(const std::string& key) const {
    return std::any_of(entries.begin(), entries.end(), [&](const Entry& e) { return e.key == key; });
  }

  // The successful entry from `from_velocity_mps` (0: a start-up from rest; speeds as keys name them,
  // two decimals) whose target speed is nearest `target_velocity_mps` (fewest strides on ties;
  // strides <= 0: any). The names are the Python runtime's (docs/library-format.md, "Names").
  const Entry& select(double target_velocity_mps, int strides = 0, double from_velocity_mps = 0.0) const {
    const Entry* best = nullptr;
    for (const auto& e : entries) {
      if (!e.success || (strides > 0 && e.n_strides != strides)) continue;
      if (std::round(e.from_velocity_mps * 100.0) != std::round(from_velocity_mps * 100.0)) continue;
      if (best == nullptr) {
        best = &e;
        continue;
      }
      const double de = std::fabs(e.target_velocity_mps - target_velocity_mps);
      const double db = std::fabs(best->target_velocity_mps - target_velocity_mps);
      if (de < db || (de == db && e.n_strides < best->n_strides)) best = &e;
    }
    if (best == nullptr) throw std::out_of_range(path + ": no successful entry from that speed with those strides");
    return *best;
  }
};

}  // namespace skatelib
