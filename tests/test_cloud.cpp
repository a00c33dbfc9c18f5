// SPDX-License-Identifier: MIT
// point_cloud (ced/cloud.hpp): fields, filtering, colour fields, origins.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ced/cloud.hpp"

namespace {

ced::point_cloud line_cloud(std::size_t n) {
  ced::point_cloud c;
  for (std::size_t i = 0; i < n; ++i)
    c.push_back(static_cast<float>(i), 10.0f * static_cast<float>(i), -static_cast<float>(i));
  return c;
}

std::vector<std::string> names(const ced::point_cloud& c) {
  std::vector<std::string> out;
  for (const auto& f : c.fields()) out.push_back(f.name);
  return out;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

}  // namespace

TEST(Cloud, AddFieldAddsAndReplacesByName) {
  auto c = line_cloud(3);
  auto& a = c.add_field("a", ced::scalar_type::uint8, std::vector<double>{1, 2, 3});
  EXPECT_EQ(a.name, "a");
  EXPECT_EQ(a.type(), ced::scalar_type::uint8);
  EXPECT_TRUE(a.values == (std::vector<double>{1, 2, 3}));
  c.add_field("b", ced::scalar_type::float32, std::vector<double>{0.5, 0.25, 0});
  c.add_field("A", ced::scalar_type::int16, std::vector<double>{-1, -2, -3});  // another name: names are exact
  EXPECT_EQ(names(c), (std::vector<std::string>{"a", "b", "A"}));
  // The same name again: replaced in place (type and values), not added.
  const auto& again = c.add_field("a", ced::scalar_type::uint16, std::vector<double>{7, 8, 9});
  EXPECT_EQ(names(c), (std::vector<std::string>{"a", "b", "A"}));
  EXPECT_EQ(&again, &c.fields()[0]);
  EXPECT_EQ(c.fields()[0].type(), ced::scalar_type::uint16);
  EXPECT_TRUE(c.fields()[0].values == (std::vector<double>{7, 8, 9}));
  EXPECT_TRUE(c.fields()[1].values == (std::vector<double>{0.5, 0.25, 0}));  // the others untouched
  EXPECT_TRUE(c.fields()[2].values == (std::vector<double>{-1, -2, -3}));
}

TEST(Cloud, AddFieldFindsNamesAfterChangesThroughFields) {
  auto c = line_cloud(2);
  for (const char* n : {"a", "b", "c", "d"}) c.add_field(n, ced::scalar_type::uint8, std::vector<double>{1, 2});
  // Removed, renamed and added through fields(): add_field sees all of it.
  auto& fs = c.fields();
  fs.erase(fs.begin());                                                     // a
  fs[0].name = "B";                                                         // b -> B
  fs.push_back({"e", ced::scalar_type::uint8, std::vector<double>{5, 6}});  // e
  c.add_field("B", ced::scalar_type::uint8, std::vector<double>{7, 7});
  c.add_field("e", ced::scalar_type::uint8, std::vector<double>{8, 8});
  c.add_field("b", ced::scalar_type::uint8, std::vector<double>{9, 9});
  c.add_field("a", ced::scalar_type::uint8, std::vector<double>{3, 3});
  EXPECT_EQ(names(c), (std::vector<std::string>{"B", "c", "d", "e", "b", "a"}));
  EXPECT_TRUE(c.get_field("B").values == (std::vector<double>{7, 7}));
  EXPECT_TRUE(c.get_field("e").values == (std::vector<double>{8, 8}));
  // keep_fields, then more: still one field a name.
  c.keep_fields(ced::field_selection::only({"d", "a"}));
  c.add_field("d", ced::scalar_type::uint8, std::vector<double>{4, 4});
  c.add_field("z", ced::scalar_type::uint8, std::vector<double>{0, 0});
  EXPECT_EQ(names(c), (std::vector<std::string>{"d", "a", "z"}));
  // A copy keeps its own index.
  auto copy = c;
  copy.add_field("z", ced::scalar_type::uint8, std::vector<double>{1, 1});
  EXPECT_EQ(names(copy), (std::vector<std::string>{"d", "a", "z"}));
  // Many fields: each added once, each replaced in place.
  ced::point_cloud wide = line_cloud(1);
  for (int k = 0; k < 50000; ++k) wide.add_field("f" + std::to_string(k), ced::scalar_type::uint8, {double(k % 7)});
  for (int k = 0; k < 50000; k += 1000) wide.add_field("f" + std::to_string(k), ced::scalar_type::uint8, {100.0});
  ASSERT_EQ(wide.fields().size(), 50000u);
  EXPECT_EQ(wide.fields()[3000].values[0], 100.0);
  EXPECT_EQ(wide.fields()[3001].values[0], double(3001 % 7));
}

TEST(Cloud, AddFieldOfTheWrongSizeThrows) {
  auto c = line_cloud(3);
  c.add_field("a", ced::scalar_type::uint8, std::vector<double>{1, 2, 3});
  for (const auto& values : {std::vector<double>{}, std::vector<double>{1, 2}, std::vector<double>{1, 2, 3, 4}}) {
    try {
      c.add_field("x", ced::scalar_type::uint8, values);
      ADD_FAILURE() << "no error for " << values.size() << " values";
    } catch (const std::invalid_argument& e) {
      EXPECT_TRUE(contains(e.what(), "'x'")) << e.what();
      EXPECT_TRUE(contains(e.what(), std::to_string(values.size()) + " values for 3 points")) << e.what();
    }
    // Replacing an existing field with the wrong size fails too, and leaves it as it was.
    EXPECT_THROW(c.add_field("a", ced::scalar_type::uint8, values), std::invalid_argument);
  }
  EXPECT_EQ(names(c), (std::vector<std::string>{"a"}));
  EXPECT_TRUE(c.fields()[0].values == (std::vector<double>{1, 2, 3}));
  // An empty cloud takes empty fields only.
  ced::point_cloud empty;
  EXPECT_NO_THROW(empty.add_field("a", ced::scalar_type::uint8, std::vector<double>{}));
  EXPECT_THROW(empty.add_field("b", ced::scalar_type::uint8, std::vector<double>{1}), std::invalid_argument);
}

TEST(Cloud, FindFieldExactAndIgnoringCase) {
  auto c = line_cloud(2);
  c.add_field("Intensity", ced::scalar_type::uint16, std::vector<double>{1, 2});
  c.add_field("NIR", ced::scalar_type::uint8, std::vector<double>{3, 4});
  c.add_field("nir", ced::scalar_type::uint8, std::vector<double>{5, 6});
  const auto& f = c.fields();
  EXPECT_EQ(c.find_field("Intensity"), &f[0]);
  EXPECT_EQ(c.find_field("intensity"), nullptr);  // exact: case matters
  EXPECT_EQ(c.find_field("Intens"), nullptr);     // whole names only
  EXPECT_EQ(c.find_field("nir"), &f[2]);
  EXPECT_EQ(c.find_field_icase("intensity"), &f[0]);
  EXPECT_EQ(c.find_field_icase("INTENSITY"), &f[0]);
  EXPECT_EQ(c.find_field_icase("intensit"), nullptr);
  EXPECT_EQ(c.find_field_icase("intensityy"), nullptr);
  EXPECT_EQ(c.find_field_icase("nir"), &f[2]);  // an exact match wins over an earlier one of another case
  EXPECT_EQ(c.find_field_icase("NIR"), &f[1]);
  EXPECT_EQ(c.find_field_icase("Nir"), &f[1]);  // no exact match: the first of any case
  EXPECT_EQ(c.find_field_icase("red"), nullptr);
  EXPECT_EQ(ced::point_cloud{}.find_field_icase(""), nullptr);
}

TEST(Cloud, GetFieldThrowsListingTheFieldsPresent) {
  auto c = line_cloud(2);
  c.add_field("red", ced::scalar_type::uint8, std::vector<double>{1, 2});
  c.add_field("nir", ced::scalar_type::uint8, std::vector<double>{3, 4});
  EXPECT_EQ(&c.get_field("nir"), &c.fields()[1]);
  EXPECT_TRUE(c.get_field("red").values == (std::vector<double>{1, 2}));
  try {
    c.get_field("NIR");  // exact names only
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "'NIR'")) << e.what();
    EXPECT_TRUE(contains(e.what(), "red, nir")) << e.what();
  }
  try {
    line_cloud(1).get_field("x");
    FAIL() << "no error";
  } catch (const std::invalid_argument& e) {
    EXPECT_TRUE(contains(e.what(), "'x'")) << e.what();
    EXPECT_TRUE(contains(e.what(), "none")) << e.what();
  }
}

TEST(Cloud, FilterKeepsPointsAndFieldValuesInOrder) {
  auto c = line_cloud(6);
  c.set_origin({1, 2, 3});
  c.add_field("a", ced::scalar_type::uint8, std::vector<double>{0, 1, 2, 3, 4, 5});
  c.add_field("b", ced::scalar_type::float64, std::vector<double>{0.5, 1.5, 2.5, 3.5, 4.5, 5.5});
  auto kept = c;
  kept.filter({0, 1, 0, 7, 255, 0});  // any non-zero value keeps
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept.positions(), (std::vector<float>{1, 10, -1, 3, 30, -3, 4, 40, -4}));
  EXPECT_TRUE(kept.get_field("a").values == (std::vector<double>{1, 3, 4}));
  EXPECT_TRUE(kept.get_field("b").values == (std::vector<double>{1.5, 3.5, 4.5}));
  EXPECT_EQ(kept.get_field("a").type(), ced::scalar_type::uint8);
  EXPECT_EQ(kept.origin(), (std::array<double, 3>{1, 2, 3}));
  // The first and the last point.
  auto ends = c;
  ends.filter({1, 0, 0, 0, 0, 1});
  EXPECT_EQ(ends.positions(), (std::vector<float>{0, 0, 0, 5, 50, -5}));
  EXPECT_TRUE(ends.get_field("b").values == (std::vector<double>{0.5, 5.5}));
  // All and none.
  auto all = c;
  all.filter(std::vector<std::uint8_t>(6, 1));
  EXPECT_EQ(all.positions(), c.positions());
  EXPECT_TRUE(all.get_field("a").values == c.get_field("a").values);
  auto none = c;
  none.filter(std::vector<std::uint8_t>(6, 0));
  EXPECT_TRUE(none.empty());
  EXPECT_EQ(none.get_field("a").values.size(), 0u);
  EXPECT_EQ(none.fields().size(), 2u);
  // A mask of another size is an error.
  EXPECT_THROW(c.filter(std::vector<std::uint8_t>(5, 1)), std::invalid_argument);
  EXPECT_THROW(c.filter(std::vector<std::uint8_t>(7, 1)), std::invalid_argument);
  EXPECT_EQ(c.size(), 6u);
}

TEST(Cloud, RgbFields) {
  auto with = [](const std::vector<std::string>& field_names) {
    auto c = line_cloud(1);
    double v = 0;
    for (const auto& name : field_names) c.add_field(name, ced::scalar_type::uint8, std::vector<double>{v++});
    return c;
  };
  EXPECT_TRUE(with({"red", "green", "blue"}).has_rgb());
  EXPECT_TRUE(with({"Red", "GREEN", "blue"}).has_rgb());
  EXPECT_TRUE(with({"r", "g", "b"}).has_rgb());
  EXPECT_TRUE(with({"R", "G", "B"}).has_rgb());
  EXPECT_FALSE(with({}).has_rgb());
  EXPECT_FALSE(with({"red", "green"}).has_rgb());
  EXPECT_FALSE(with({"red", "green", "b"}).has_rgb());  // one naming or the other, not a mix
  EXPECT_FALSE(with({"r", "g", "blue"}).has_rgb());
  EXPECT_FALSE(with({"reds", "greens", "blues"}).has_rgb());

  // red/green/blue in that order, whatever the cloud's order.
  const auto bgr = with({"blue", "green", "red"});
  auto f = ced::find_rgb_fields(bgr);
  EXPECT_EQ(f[0], bgr.find_field("red"));
  EXPECT_EQ(f[1], bgr.find_field("green"));
  EXPECT_EQ(f[2], bgr.find_field("blue"));
  // red/green/blue before r/g/b, though r/g/b come first.
  const auto both = with({"r", "g", "b", "Red", "Green", "Blue"});
  f = ced::find_rgb_fields(both);
  EXPECT_EQ(f[0], both.find_field("Red"));
  EXPECT_EQ(f[1], both.find_field("Green"));
  EXPECT_EQ(f[2], both.find_field("Blue"));
  const auto short_names = with({"b", "g", "r", "red"});
  f = ced::find_rgb_fields(short_names);
  EXPECT_EQ(f[0], short_names.find_field("r"));
  EXPECT_EQ(f[1], short_names.find_field("g"));
  EXPECT_EQ(f[2], short_names.find_field("b"));
  // Absent: three nullptrs.
  f = ced::find_rgb_fields(with({"red", "green"}));
  EXPECT_EQ(f, (std::array<const ced::field*, 3>{nullptr, nullptr, nullptr}));
  // add_rgb makes uint8 red/green/blue fields.
  auto c = line_cloud(2);
  c.add_rgb({{1, 2, 3}, {4, 5, 255}});
  EXPECT_TRUE(c.has_rgb());
  EXPECT_EQ(names(c), (std::vector<std::string>{"red", "green", "blue"}));
  EXPECT_EQ(c.get_field("green").type(), ced::scalar_type::uint8);
  EXPECT_TRUE(c.get_field("red").values == (std::vector<double>{1, 4}));
  EXPECT_TRUE(c.get_field("blue").values == (std::vector<double>{3, 255}));
}

TEST(Cloud, ChooseOriginFromBounds) {
  auto origin = [](std::array<double, 3> lo, std::array<double, 3> hi) {
    return ced::choose_origin(lo.data(), hi.data());
  };
  using o3 = std::array<double, 3>;
  // Small coordinates: no origin.
  EXPECT_EQ(origin({-5, 0, 1}, {5, 20, 2}), (o3{0, 0, 0}));
  // Georeferenced: the centre rounded to whole units, per axis.
  EXPECT_EQ(origin({499990.2, 3999950.0, 90}, {500010.6, 4000050.0, 110}), (o3{500000, 4000000, 0}));
  EXPECT_EQ(origin({-500010.0, 0, 0}, {-499990.0, 1, 1}), (o3{-500000, 0, 0}));
  EXPECT_EQ(origin({20000.4, 0, 0}, {20000.4, 0, 0}), (o3{20000, 0, 0}));  // a single point
  EXPECT_EQ(origin({20000.6, 0, 0}, {20000.6, 0, 0}), (o3{20001, 0, 0}));
  // The centre must lie beyond 1e4 (strictly) ...
  EXPECT_EQ(origin({10000, 0, 0}, {10000, 0, 0}), (o3{0, 0, 0}));
  EXPECT_EQ(origin({10001, 0, 0}, {10001, 0, 0}), (o3{10001, 0, 0}));
  // ... and beyond the box's extent: a box that spans far around zero keeps 0.
  EXPECT_EQ(origin({20000, 0, 0}, {100000, 0, 0}), (o3{0, 0, 0}));  // centre 60000, extent 80000
  EXPECT_EQ(origin({-30000, 0, 0}, {150000, 0, 0}), (o3{0, 0, 0}));
  EXPECT_EQ(origin({50000, 0, 0}, {90000, 0, 0}), (o3{70000, 0, 0}));  // centre 70000, extent 40000
}

TEST(Cloud, ChooseOriginFromPointsSkipsNonFinite) {
  using o3 = std::array<double, 3>;
  const std::vector<double> x = {500001.0, 499999.0, NAN, 600000.0}, y = {3000000.0, 3000002.0, 3100000.0, 3000001.0},
                            z = {100.0, 101.0, 0, INFINITY};
  // Points 2 and 3 have a non-finite coordinate: they do not count, on any
  // axis (counted, point 2 would move y's origin and point 3 x's).
  const auto o = ced::choose_origin(x.data(), y.data(), z.data(), x.size());
  const double lo[3] = {499999.0, 3000000.0, 100}, hi[3] = {500001.0, 3000002.0, 101};
  EXPECT_EQ(o, ced::choose_origin(lo, hi));
  EXPECT_EQ(o, (o3{500000, 3000001, 0}));
  // Only the first point: its own position.
  EXPECT_EQ(ced::choose_origin(x.data(), y.data(), z.data(), 1), (o3{500001, 3000000, 0}));
  // No points, or none finite: no origin.
  EXPECT_EQ(ced::choose_origin(x.data(), y.data(), z.data(), 0), (o3{0, 0, 0}));
  const std::vector<double> bad = {NAN, INFINITY}, far = {1e6, 1e6};
  EXPECT_EQ(ced::choose_origin(bad.data(), far.data(), far.data(), 2), (o3{0, 0, 0}));
  // Georeferenced points all on one side of zero, and a cloud whose first
  // point is not the minimum.
  const std::vector<double> gx = {-700005.0, -700010.0, -700000.0}, gy = {1, 2, 3}, gz = {20000, 20002, 20004};
  EXPECT_EQ(ced::choose_origin(gx.data(), gy.data(), gz.data(), 3), (o3{-700005, 0, 20002}));
}

TEST(Column, ViewReadsWithoutCopyingAndCopiesOnFirstWrite) {
  std::vector<std::uint16_t> storage = {10, 20, 300, 4000};
  auto owner = std::make_shared<int>(0);
  std::weak_ptr<int> alive = owner;
  {
    const ced::column v = ced::column::view(ced::scalar_type::uint16, storage.data(), storage.size(), owner);
    owner.reset();
    EXPECT_TRUE(v.is_view());
    EXPECT_EQ(v.data<std::uint16_t>(), storage.data());  // no copy (const access never copies)
    EXPECT_EQ(v[2], 300.0);
    storage[2] = 301;  // the view sees the memory it reads
    EXPECT_EQ(v[2], 301.0);
    ced::column shared = v;  // copies share the memory and the owner
    EXPECT_TRUE(shared.is_view());
    EXPECT_EQ(std::as_const(shared).bytes(), v.bytes());
    shared.set(0, 11);  // the first write copies
    EXPECT_FALSE(shared.is_view());
    EXPECT_EQ(storage[0], 10);
    EXPECT_EQ(shared[0], 11.0);
    EXPECT_EQ(shared[3], 4000.0);
    ced::point_cloud c;
    c.resize(4);
    c.add_field("i", v);
    EXPECT_EQ(std::as_const(c).get_field("i").values.data<std::uint16_t>(), storage.data());
    c.filter({1, 0, 1, 1});  // filtering writes: the field gets its own values
    EXPECT_EQ(c.get_field("i").values, (std::vector<double>{10, 301, 4000}));
    EXPECT_EQ(storage[1], 20);
    EXPECT_FALSE(alive.expired());  // v still holds the owner
  }
  EXPECT_TRUE(alive.expired());  // released with the last view
}

TEST(Column, LargeColumnsAreZeroedAlignedAndGrowKeepingTheirValues) {
  // Columns from 1 MiB on take whole huge pages (detail::allocate_column):
  // the same zeros, values and copies as small ones, aligned for any type.
  for (const std::size_t n : {std::size_t(1000), std::size_t(300'000), std::size_t(1'500'000)}) {
    ced::column c(ced::scalar_type::float64, n);
    ASSERT_EQ(c.size(), n);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(c.bytes()) % alignof(std::max_align_t), 0u);
    bool zeros = true;
    for (std::size_t i = 0; i < n; ++i) zeros = zeros && c[i] == 0.0;
    EXPECT_TRUE(zeros) << n;
    c.set(n - 1, 7.5);
    c.resize(2 * n);  // grows across the 1 MiB threshold for n = 300'000
    EXPECT_EQ(c[n - 1], 7.5);
    EXPECT_EQ(c[2 * n - 1], 0.0);
    const ced::column copy = c;
    EXPECT_EQ(copy, c);
    c.resize(1);  // shrinks in place
    EXPECT_EQ(c.size(), 1u);
  }
}
