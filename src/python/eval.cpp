// SPDX-License-Identifier: MIT
// ced.eval's primitives: seeded random transforms, noisy copies, the
// repeatability measure, random keypoints (ced/eval.py builds the protocol).
#include "ced/eval.hpp"

#include <pybind11/stl.h>

#include <random>
#include <string>
#include <vector>

#include "bindings.hpp"

CED_PYTHON_CHECKED_CLASS(std::mt19937_64)

namespace ced_python {
namespace {

using ced::eval::rigid_transform;

py::array_t<double> to_matrix(const rigid_transform& t) {
  py::array_t<double> m({4, 4});
  auto a = m.mutable_unchecked<2>();
  for (py::ssize_t r = 0; r < 4; ++r)
    for (py::ssize_t c = 0; c < 4; ++c)
      a(r, c) = r == 3 ? (c == 3 ? 1.0 : 0.0) : c == 3 ? t.translation[r] : t.rotation[r][c];
  return m;
}

rigid_transform from_matrix(py::handle matrix) {
  const auto m = py::array_t<double, py::array::forcecast>::ensure(matrix);
  if (!m || m.ndim() != 2 || m.shape(0) != 4 || m.shape(1) != 4)
    throw py::value_error("transform: expected a 4x4 matrix");
  rigid_transform t;
  for (py::ssize_t r = 0; r < 3; ++r) {
    for (py::ssize_t c = 0; c < 3; ++c) t.rotation[r][c] = m.at(r, c);
    t.translation[r] = m.at(r, 3);
  }
  for (py::ssize_t i = 0; i < 16; ++i)
    if (!std::isfinite(m.at(i / 4, i % 4))) throw py::value_error("transform: the matrix has a non-finite entry");
  return t;
}

}  // namespace

void bind_eval(py::module_& root) {
  py::module_ m = root.def_submodule("_eval", "ced.eval's primitives");
  py::class_<std::mt19937_64>(m, "Random", "The seeded generator of the CLI's evaluation (std::mt19937_64).")
      .def(py::init<std::uint64_t>(), py::arg("seed"))
      .def(
          "next", [](std::mt19937_64& g) { return g(); }, "The next 64-bit value.");
  m.def(
      "random_transform",
      [](std::mt19937_64& rng, double max_translation) {
        if (!(max_translation >= 0) || !std::isfinite(max_translation))
          throw py::value_error("max_translation: must be a finite number >= 0");
        return to_matrix(ced::eval::random_transform(rng, max_translation));
      },
      py::arg("rng"), py::arg("max_translation"),
      "A 4x4 rigid transform: rotation uniform over SO(3), translation uniform in [-t, t]^3.");
  m.def(
      "transform",
      [](py::handle cloud, py::handle matrix, double sigma, std::mt19937_64& rng) {
        if (!(sigma >= 0) || !std::isfinite(sigma)) throw py::value_error("sigma: must be a finite number >= 0");
        const cloud_ptr c = to_cloud(cloud, py::none());
        const rigid_transform t = from_matrix(matrix);
        released_gil release;
        return std::make_shared<ced::point_cloud>(ced::eval::transform(*c, t, sigma, rng));
      },
      py::arg("cloud"), py::arg("transform"), py::arg("sigma"), py::arg("rng"),
      "The moved cloud, with Gaussian noise of standard deviation `sigma` on every coordinate.");
  m.def(
      "measure",
      [](py::handle p, py::handle kp, py::handle q, py::handle kq, py::handle matrix, double epsilon) {
        if (!(epsilon > 0) || !std::isfinite(epsilon)) throw py::value_error("epsilon: must be a positive number");
        const cloud_ptr a = to_cloud(p, py::none()), b = to_cloud(q, py::none());
        const auto ka = to_indices(kp, "source_keypoints", a->size());
        const auto kb = to_indices(kq, "target_keypoints", b->size());
        const rigid_transform t = from_matrix(matrix);
        const auto r = ced::eval::measure(*a, ka, *b, kb, t, epsilon);
        return py::make_tuple(r.source_keypoints, r.target_keypoints, r.repeated);
      },
      py::arg("source"), py::arg("source_keypoints"), py::arg("target"), py::arg("target_keypoints"),
      py::arg("transform"), py::arg("epsilon"), "(|K_P|, |K_Q|, repeated).");
  m.def(
      "random_keypoints",
      [](std::size_t n, std::size_t count, std::mt19937_64& rng) {
        const auto k = ced::eval::random_keypoints(n, std::min(n, count), rng);
        return py::array_t<std::uint32_t>(py::ssize_t(k.size()), k.data());
      },
      py::arg("n"), py::arg("count"), py::arg("rng"),
      "`count` distinct indices of [0, n), ascending: the random baseline.");
}

}  // namespace ced_python
