// SPDX-License-Identifier: MIT
// Channels (ced/channels.hpp): value ranges, interleaving fields into float
// rows, and finding and checking the fields a modality reads.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "ced/ced.hpp"
#include "ced/channels.hpp"
#include "ced/cloud.hpp"
#include "core/kernel/dispatch.hpp"
#include "test_support.hpp"

namespace {

/// The message of the std::invalid_argument `f` throws, or "" when it throws none.
template <class F>
std::string invalid_argument_of(F&& f) {
  try {
    f();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

/// A cloud of n points on the x axis.
ced::point_cloud line_cloud(std::size_t n) {
  ced::point_cloud c;
  for (std::size_t i = 0; i < n; ++i) c.push_back(static_cast<float>(i), 0.0f, 0.0f);
  return c;
}

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

/// `text` says "at point <i>" (and not a longer number starting with i's digits).
bool names_point(const std::string& text, std::size_t i) {
  const std::string part = "at point " + std::to_string(i);
  const auto at = text.find(part);
  if (at == std::string::npos) return false;
  const auto next = at + part.size();
  return next == text.size() || !std::isdigit(static_cast<unsigned char>(text[next]));
}

}  // namespace

TEST(Channels, RangePolicyParsesGoodTexts) {
  EXPECT_EQ(ced::range_policy{}.how, ced::range_policy::kind::natural);
  EXPECT_EQ(ced::range_policy::parse("auto").how, ced::range_policy::kind::data);
  struct good {
    const char* text;
    double lo, hi;
  };
  for (const good& g : {good{"0..255", 0, 255}, good{"-1..1", -1, 1}, good{"0.25..0.5", 0.25, 0.5},
                        good{"-10..-2.5", -10, -2.5}, good{"1e-3..2e3", 1e-3, 2e3}}) {
    const auto p = ced::range_policy::parse(g.text);
    EXPECT_EQ(p.how, ced::range_policy::kind::fixed) << g.text;
    EXPECT_EQ(p.fixed.lo, g.lo) << g.text;
    EXPECT_EQ(p.fixed.hi, g.hi) << g.text;
  }
}

TEST(Channels, RangePolicyRejectsBadTextsNamingTheOption) {
  for (const char* bad :
       {"", "0", "0-255", "auto..1", "a..b", "0..", "..1", "0..1x", "5..1", "1..1", "nan..1", "0..inf", "Auto"}) {
    const auto what = invalid_argument_of([&] { ced::range_policy::parse(bad, "my-range"); });
    EXPECT_TRUE(contains(what, "my-range")) << "'" << bad << "': " << what;
  }
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("0-255"); }), "LO..HI"));
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("5..1"); }), "high end"));
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("3..3"); }), "high end"));
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("x..1"); }), "low end"));
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("0..y"); }), "high end"));
  // The default option name.
  EXPECT_TRUE(contains(invalid_argument_of([] { ced::range_policy::parse("?"); }), "'range'"));
}

TEST(Channels, ResolveRange) {
  auto c = line_cloud(4);
  c.add_field("u8", ced::scalar_type::uint8, std::vector<double>{3, 2, 7, 1});
  c.add_field("i16", ced::scalar_type::int16, std::vector<double>{5, 5, 5, 5});
  c.add_field("u16", ced::scalar_type::uint16, std::vector<double>{0, 1, 2, 3});
  c.add_field("f", ced::scalar_type::float32, std::vector<double>{0.5, 0.25, 0.75, 0.5});
  const auto& u8 = c.get_field("u8");
  const auto& i16 = c.get_field("i16");
  const auto& u16 = c.get_field("u16");
  const auto& f = c.get_field("f");
  auto expect_range = [](const ced::value_range& got, double lo, double hi, const char* what) {
    EXPECT_EQ(got.lo, lo) << what;
    EXPECT_EQ(got.hi, hi) << what;
  };
  // Natural: the type's range; floats are taken as they are ([0, 1]).
  const ced::range_policy natural;
  expect_range(ced::resolve_range(u8, natural), 0, 255, "natural uint8");
  expect_range(ced::resolve_range(i16, natural), -32768, 32767, "natural int16");
  expect_range(ced::resolve_range(u16, natural), 0, 65535, "natural uint16");
  expect_range(ced::resolve_range(f, natural), 0, 1, "natural float32");
  // Fixed: the given range, whatever the field.
  const auto fixed = ced::range_policy::parse("-4..12");
  expect_range(ced::resolve_range(u8, fixed), -4, 12, "fixed");
  expect_range(ced::resolve_range(f, fixed), -4, 12, "fixed");
  // Data: the values' own min..max (the minimum and maximum are not first
  // nor last here).
  const auto data = ced::range_policy::parse("auto");
  expect_range(ced::resolve_range(u8, data), 1, 7, "data");
  expect_range(ced::resolve_range(f, data), 0.25, 0.75, "data float");
  // A degenerate data range (all values equal) becomes [lo, lo + 1].
  expect_range(ced::resolve_range(i16, data), 5, 6, "degenerate data");
  auto one = line_cloud(1);
  one.add_field("v", ced::scalar_type::float64, std::vector<double>{-3.5});
  expect_range(ced::resolve_range(one.get_field("v"), data), -3.5, -2.5, "one value");
  // No values: [0, 1].
  auto none = line_cloud(0);
  none.add_field("v", ced::scalar_type::uint8, std::vector<double>{});
  expect_range(ced::resolve_range(none.get_field("v"), data), 0, 1, "no values");
}

TEST(Channels, InterleaveIsRowMajor) {
  auto c = line_cloud(3);
  c.add_field("a", ced::scalar_type::float64, std::vector<double>{1, 2, 3});
  c.add_field("b", ced::scalar_type::float64, std::vector<double>{10, 20, 30});
  c.add_field("c", ced::scalar_type::float64, std::vector<double>{0.1, -0.2, 1e30});
  const auto* a = c.find_field("a");
  const auto* b = c.find_field("b");
  const auto* cc = c.find_field("c");
  EXPECT_EQ(ced::interleave({a, b, cc}),
            (std::vector<float>{1, 10, 0.1f, 2, 20, -0.2f, 3, 30, static_cast<float>(1e30)}));
  // In the order given, not the cloud's.
  EXPECT_EQ(ced::interleave({cc, a}), (std::vector<float>{0.1f, 1, -0.2f, 2, static_cast<float>(1e30), 3}));
  EXPECT_EQ(ced::interleave({b}), (std::vector<float>{10, 20, 30}));
  EXPECT_TRUE(ced::interleave({}).empty());
}

TEST(Channels, InterleaveIsTheSameForAnyThreadCount) {
  // More points than one chunk of the parallel loop (2^15), not a multiple of it.
  const std::size_t n = 100003;
  auto c = line_cloud(n);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1000.0, 1000.0);
  std::vector<const ced::field*> fields;
  for (const char* name : {"x0", "x1", "x2", "x3", "x4"}) {
    std::vector<double> v(n);
    for (auto& x : v) x = u(rng);
    c.add_field(name, ced::scalar_type::float64, std::move(v));
  }
  for (const auto& f : c.fields()) fields.push_back(&f);
  const auto one = ced::interleave(fields);
  ASSERT_EQ(one.size(), n * fields.size());
  for (std::size_t i = 0; i < n; i += 997)
    for (std::size_t k = 0; k < fields.size(); ++k)
      ASSERT_EQ(one[i * fields.size() + k], static_cast<float>(fields[k]->values[i])) << i << " " << k;
  for (std::size_t k = 0; k < fields.size(); ++k)  // the last row
    ASSERT_EQ(one[(n - 1) * fields.size() + k], static_cast<float>(fields[k]->values[n - 1]));
  for (const unsigned threads : {0u, 1u, 2u, 3u, 8u}) EXPECT_EQ(ced::interleave(fields, threads), one) << threads;
}

TEST(Channels, InterleaveNamesTheFieldAndPointOfABadValue) {
  auto c = line_cloud(5000);
  std::vector<double> good(5000, 1.0), bad(5000, 2.0);
  bad[4321] = std::nan("");
  c.add_field("good", ced::scalar_type::float64, good);
  c.add_field("bad", ced::scalar_type::float64, bad);
  const auto what = invalid_argument_of([&] { ced::interleave({c.find_field("good"), c.find_field("bad")}, 2); });
  EXPECT_TRUE(contains(what, "field 'bad'")) << what;
  EXPECT_TRUE(names_point(what, 4321)) << what;
  bad[4321] = 1e300;  // finite, but infinite as a float
  c.add_field("bad", ced::scalar_type::float64, bad);
  EXPECT_TRUE(names_point(invalid_argument_of([&] { ced::interleave({c.find_field("bad")}); }), 4321));
}

TEST(Channels, RequireFieldsMatchesExactNamesFirstThenAnyCase) {
  auto c = line_cloud(2);
  c.add_field("RED", ced::scalar_type::uint8, std::vector<double>{1, 2});
  c.add_field("red", ced::scalar_type::uint8, std::vector<double>{3, 4});
  c.add_field("Nir", ced::scalar_type::uint16, std::vector<double>{5, 6});
  const auto f = ced::require_fields(c, {"red", "nir", "Red", "RED"}, "test");
  ASSERT_EQ(f.size(), 4u);
  EXPECT_EQ(f[0], c.find_field("red"));  // exact, though "RED" comes first
  EXPECT_EQ(f[1], c.find_field("Nir"));  // any case
  EXPECT_EQ(f[2], c.find_field("RED"));  // no exact match: the first of any case
  EXPECT_EQ(f[3], c.find_field("RED"));
  EXPECT_TRUE(ced::require_fields(c, {}, "test").empty());
}

TEST(Channels, RequireFieldsNamesTheMissingFieldAndListsThePresentOnes) {
  auto c = line_cloud(2);
  c.add_field("intensity", ced::scalar_type::uint16, std::vector<double>{1, 2});
  c.add_field("nir", ced::scalar_type::uint8, std::vector<double>{3, 4});
  const auto what = invalid_argument_of([&] { ced::require_fields(c, {"nir", "red_edge"}, "bands(nir,red_edge)"); });
  EXPECT_TRUE(contains(what, "modality 'bands(nir,red_edge)'")) << what;
  EXPECT_TRUE(contains(what, "field 'red_edge'")) << what;
  EXPECT_TRUE(contains(what, "intensity, nir")) << what;
  const auto empty = line_cloud(2);
  const auto none = invalid_argument_of([&] { ced::require_fields(empty, {"red"}, "rgb"); });
  EXPECT_TRUE(contains(none, "field 'red'")) << none;
  EXPECT_TRUE(contains(none, "none")) << none;
  // A field that is found but holds a non-finite value is an error too.
  c.add_field("nir", ced::scalar_type::float32, std::vector<double>{3, INFINITY});  // floats hold infinities
  const auto inf = invalid_argument_of([&] { ced::require_fields(c, {"intensity", "NIR"}, "m"); });
  EXPECT_TRUE(contains(inf, "field 'nir'")) << inf;
  EXPECT_TRUE(names_point(inf, 1)) << inf;
}

TEST(Channels, RequireFieldsPointsToAPrefixedFieldOfTheSameName) {
  // CloudCompare writes scalar fields as scalar_<name>: the message says
  // which field is meant and how to name it.
  auto c = line_cloud(2);
  c.add_field("scalar_Intensity", ced::scalar_type::float32, std::vector<double>{1, 2});
  const auto what = invalid_argument_of([&] { ced::require_fields(c, {"intensity"}, "intensity"); });
  EXPECT_TRUE(contains(what, "did you mean 'scalar_Intensity'?")) << what;
  EXPECT_TRUE(contains(what, "intensity(scalar_Intensity):THRESHOLD")) << what;
  const auto band = invalid_argument_of([&] { ced::require_fields(c, {"intensity"}, "bands(intensity)"); });
  EXPECT_TRUE(contains(band, "did you mean 'scalar_Intensity'?")) << band;
  EXPECT_FALSE(contains(band, "Name it in the spec")) << band;
  // No hint for a field that only contains the name.
  auto d = line_cloud(2);
  d.add_field("intensity_raw", ced::scalar_type::float32, std::vector<double>{1, 2});
  const auto none = invalid_argument_of([&] { ced::require_fields(d, {"intensity"}, "intensity"); });
  EXPECT_FALSE(contains(none, "did you mean")) << none;
  // The same hint from a list of names (the CLI lists a file's own fields).
  EXPECT_EQ(ced::missing_field_hint({"red", "scalar_nir"}, "NIR", "bands(nir)"), "; did you mean 'scalar_nir'?");
  EXPECT_EQ(ced::missing_field_hint({"nir"}, "nir", "bands(nir)"), "");
}

TEST(Channels, RequireFiniteNamesModalityFieldAndPoint) {
  const double flt_max = std::numeric_limits<float>::max();
  const std::size_t n = 9000;  // more than two chunks of the check (4096)
  auto c = line_cloud(n);
  std::vector<double> v(n, 0.5);
  v[0] = flt_max;
  v[1] = -flt_max;
  v[2] = 1e-320;  // subnormal
  v[3] = -0.0;
  c.add_field("h", ced::scalar_type::float64, v);
  EXPECT_NO_THROW(ced::require_finite(c.get_field("h"), "bands(h)"));
  struct bad_value {
    double value;
    const char* says;
  };
  for (const bad_value& b : {bad_value{std::nan(""), "non-finite value"}, bad_value{INFINITY, "non-finite value"},
                             bad_value{-INFINITY, "non-finite value"},
                             bad_value{std::nextafter(flt_max, INFINITY), "beyond the float range"},
                             bad_value{-1e300, "beyond the float range"}})
    for (const std::size_t at : {std::size_t(0), std::size_t(4095), std::size_t(4096), n - 1}) {
      std::vector<double> w(n, 0.5);
      w[at] = b.value;
      if (at + 1 < n) w[n - 1] = std::nan("");  // only the first bad value is named
      c.add_field("h", ced::scalar_type::float64, w);
      const auto what = invalid_argument_of([&] { ced::require_finite(c.get_field("h"), "bands(h)"); });
      SCOPED_TRACE(testing::Message() << b.value << " at " << at << ": " << what);
      EXPECT_TRUE(contains(what, "modality 'bands(h)'"));
      EXPECT_TRUE(contains(what, "field 'h'"));
      EXPECT_TRUE(contains(what, b.says));
      EXPECT_TRUE(names_point(what, at));
    }
}

TEST(Channels, NarrowValuesInWideIntegerFields) {
  ced::point_cloud c = line_cloud(4);
  c.add_field("a", ced::scalar_type::int64, std::vector<double>{0, 10, 255, 3});
  c.add_field("b", ced::scalar_type::uint32, std::vector<double>{0, 10, 256, 3});
  c.add_field("c", ced::scalar_type::int32, std::vector<double>{0, 10, 65536, 3});
  c.add_field("d", ced::scalar_type::int64, std::vector<double>{0, -1, 25, 3});
  c.add_field("e", ced::scalar_type::uint16, std::vector<double>{0, 10, 255, 3});
  const auto range = [&](const char* name) { return ced::narrow_integer_range(c.get_field(name)); };
  ASSERT_TRUE(range("a") && range("b"));
  EXPECT_EQ(range("a")->hi, 255.0);
  EXPECT_EQ(range("b")->hi, 65535.0);
  EXPECT_FALSE(range("c"));            // beyond 16 bits
  EXPECT_FALSE(range("d"));            // negative
  EXPECT_FALSE(range("e"));            // 16 bits: holds_8bit_in_16's case
  ced::field tile = c.get_field("a");  // a tile judges by the whole cloud's range
  tile.whole_range = ced::value_range{0, 1000};
  EXPECT_EQ(ced::narrow_integer_range(tile)->hi, 65535.0);
}

TEST(Channels, ColoursAndIntensitiesInInt64GiveTheKeypointsOfUint8) {
  // numpy's default integers: by their type's range (2^64) the colours vanished.
  const ced::point_cloud room = ced_test::make_room(3000, 5);
  ced::point_cloud wide;
  for (std::size_t i = 0; i < room.size(); ++i) {
    const float* q = room.position(i);
    wide.push_back(q[0], q[1], q[2]);
  }
  for (const char* name : {"red", "green", "blue"})
    wide.add_field(name, ced::scalar_type::int64, room.get_field(name).values.to_doubles());
  wide.add_field("intensity", ced::scalar_type::uint32, room.get_field("red").values.to_doubles());
  ced::point_cloud narrow = room;
  narrow.add_field("intensity", ced::scalar_type::uint8, room.get_field("red").values.to_doubles());
  ced::detect_params p;
  for (const char* spec : {"rgb:0.1", "lab:0.1", "intensity:0.05"}) {
    const auto a = ced::detect(narrow, p, {ced::make_modality("xyz:0.2"), ced::make_modality(spec)});
    const auto b = ced::detect(wide, p, {ced::make_modality("xyz:0.2"), ced::make_modality(spec)});
    EXPECT_EQ(a.keypoints, b.keypoints) << spec;
    EXPECT_EQ(a.saliency[1], b.saliency[1]) << spec;
  }
}

TEST(Channels, EightBitValuesIn16BitFields) {
  ced::point_cloud c = line_cloud(4);
  c.add_field("a", ced::scalar_type::uint16, std::vector<double>{0, 10, 255, 3});
  c.add_field("b", ced::scalar_type::uint16, std::vector<double>{0, 10, 256, 3});
  c.add_field("c", ced::scalar_type::uint8, std::vector<double>{0, 10, 255, 3});
  c.add_field("d", ced::scalar_type::int16, std::vector<double>{0, -1, 25, 3});
  EXPECT_TRUE(ced::holds_8bit_in_16(c.get_field("a")));
  EXPECT_FALSE(ced::holds_8bit_in_16(c.get_field("b")));
  EXPECT_FALSE(ced::holds_8bit_in_16(c.get_field("c")));  // 8-bit already
  EXPECT_FALSE(ced::holds_8bit_in_16(c.get_field("d")));  // negative
  // A tile judges by the whole cloud's range.
  ced::field tile = c.get_field("a");
  tile.whole_range = ced::value_range{0, 1000};
  EXPECT_FALSE(ced::holds_8bit_in_16(tile));
}

// Many bands by a range or a glob, in every way a spec is given.
TEST(Channels, BandRangesAndGlobs) {
  using names = std::vector<std::string>;
  EXPECT_EQ(ced::expand_field_ranges({"b000..b003"}), (names{"b000", "b001", "b002", "b003"}));
  EXPECT_EQ(ced::expand_field_ranges({"b08..b11"}), (names{"b08", "b09", "b10", "b11"}));
  EXPECT_EQ(ced::expand_field_ranges({"b1..b3", "nir"}), (names{"b1", "b2", "b3", "nir"}));
  EXPECT_EQ(ced::expand_field_ranges({"band_9..band_11"}), (names{"band_9", "band_10", "band_11"}));
  EXPECT_EQ(ced::expand_field_ranges({"B2..b2"}), (names{"B2"}));
  EXPECT_EQ(ced::expand_field_ranges({"b*"}), (names{"b*"}));
  for (const char* bad : {"b3..b1", "b..b3", "a1..b3", "b1..", "..b3", "b0..b99999999"})
    EXPECT_THROW(ced::expand_field_ranges({bad}), std::invalid_argument) << bad;
  EXPECT_TRUE(ced::field_name_matches("b*", "B017"));
  EXPECT_TRUE(ced::field_name_matches("*_nm", "band_550_nm"));
  EXPECT_TRUE(ced::field_name_matches("b?", "b7"));
  EXPECT_TRUE(ced::field_name_matches("*", ""));
  EXPECT_TRUE(ced::field_name_matches("a*b*c", "axxbyyc"));
  EXPECT_FALSE(ced::field_name_matches("b?", "b17"));
  EXPECT_FALSE(ced::field_name_matches("a*b*c", "axxbyy"));
  EXPECT_FALSE(ced::field_name_matches("nir", "nir2"));

  // A cloud with 12 bands and colour: bands(b00..b11), bands(b*) and the
  // names typed one by one read the same fields and give the same result.
  auto c = ced_test::make_room(3000, 29);
  std::mt19937 rng(5);
  names typed;
  for (int b = 0; b < 12; ++b) {
    std::vector<double> v(c.size());
    for (double& x : v) x = double(rng() % 1000);
    typed.push_back((b < 10 ? "b0" : "b") + std::to_string(b));
    c.add_field(typed.back(), ced::scalar_type::uint16, std::move(v));
  }
  ced::detect_params p;
  p.threads = 2;
  const auto want = ced::detect(c, p, std::vector<ced::any_modality>{ced::bands(typed, 0.05)});
  ASSERT_GT(want.keypoints.size(), 5u);
  // (b* would take "blue" too: the room has colour.)
  for (const auto& [spec, fields] :
       std::vector<std::pair<const char*, names>>{{"bands(b00..b11):0.05", typed},
                                                  {"bands(b?\?):0.05", {"b?\?"}},
                                                  {"bands(B0?,b10..b11):0.05", {"B0?", "b10", "b11"}}}) {
    SCOPED_TRACE(spec);
    const auto m = ced::make_modality(spec);
    EXPECT_EQ(*m.fields(), fields);  // ranges expanded, globs kept as patterns
    const auto got = ced::detect(c, p, std::vector<ced::any_modality>{m});
    EXPECT_EQ(got.saliency, want.saliency);
    EXPECT_EQ(got.keypoints, want.keypoints);
  }
  // A field selection keeps what a glob matches.
  const auto only = ced::field_selection::only({"b*", "nir"});
  EXPECT_TRUE(only.wants("B03"));
  EXPECT_TRUE(only.wants("NIR"));
  EXPECT_FALSE(only.wants("red"));
  // Clear errors: nothing matched, a field named twice, a bad pattern.
  const auto none = invalid_argument_of(
      [&] { ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(swir*)")}); });
  EXPECT_NE(none.find("'swir*' matches no field"), std::string::npos) << "[" << none << "]";
  EXPECT_NE(none.find("b00"), std::string::npos) << none;  // the fields present
  const auto twice = invalid_argument_of(
      [&] { ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(b?\?,b03)")}); });
  EXPECT_NE(twice.find("names field 'b03' twice"), std::string::npos) << twice;
  EXPECT_THROW(ced::make_modality("bands(b$)"), std::invalid_argument);
  const auto backwards = invalid_argument_of(
      [&] { ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(b11..b00)")}); });
  EXPECT_NE(backwards.find("runs backwards"), std::string::npos) << backwards;
  // Integer bands (scaled by their type's range) beside float bands that are
  // not in [0, 1] (taken as they are): an error naming the float band, its
  // values and the ranges that give both one scale, which then work. Float
  // bands already in [0, 1] mix as documented.
  auto mixed = c;
  std::vector<double> dn(mixed.size(), 250.0), refl(mixed.size(), 0.25);
  dn[7] = 4000.0;
  mixed.add_field("dn", ced::scalar_type::float32, dn);
  mixed.add_field("refl", ced::scalar_type::float32, refl);
  const auto mix = invalid_argument_of(
      [&] { ced::detect(mixed, p, std::vector<ced::any_modality>{ced::make_modality("bands(b00,dn)")}); });
  EXPECT_NE(mix.find("with float band 'dn' (float32, 250 .. 4000)"), std::string::npos) << mix;
  EXPECT_NE(mix.find("range=auto"), std::string::npos) << mix;
  EXPECT_NO_THROW(
      ced::detect(mixed, p, std::vector<ced::any_modality>{ced::make_modality("bands(b00,dn),range=auto")}));
  EXPECT_NO_THROW(ced::detect(mixed, p, std::vector<ced::any_modality>{ced::make_modality("bands(b00,refl)")}));
}

// Past 16 channels the pass sums whole rows of channels (one float sum a
// channel in sweep order): the saliencies and keypoints of 17, 40 and 200
// bands are those of the definition, on every build of the pass.
TEST(Channels, ManyBandsMatchTheOracle) {
  for (const std::size_t bands : {std::size_t(17), std::size_t(40), std::size_t(200)}) {
    SCOPED_TRACE(std::to_string(bands) + " bands");
    auto c = ced_test::make_room(2500, 31);
    std::mt19937 rng{static_cast<unsigned>(bands)};
    std::uniform_real_distribution<double> u(0.0, 1.0);
    ced_test::oracle_channel ch;
    ch.values.assign(c.size(), std::vector<double>(bands));
    for (std::size_t b = 0; b < bands; ++b) {
      std::vector<double> v(c.size());
      for (std::size_t i = 0; i < c.size(); ++i)
        v[i] = ch.values[i][b] = double(float(0.3 * std::sin(7.0 * c.position(i)[0] + 0.1 * double(b)) + 0.2 * u(rng)));
      c.add_field("s" + std::to_string(1000 + b), ced::scalar_type::float32, std::move(v));
    }
    ch.scale.assign(bands, 1.0);
    ch.norm = 1;
    ch.threshold = 0.05 * double(bands);
    ced::detect_params p;
    p.threads = 2;
    const auto o = ced_test::oracle(c, {ch}, p.radius, p.nms_radius, p.min_neighbors);
    for (const std::string& isa : ced::detail::kernel_isas()) {
      SCOPED_TRACE(isa);
      ced::detail::force_kernel_isa(isa);
      const auto got = ced::detect(c, p,
                                   std::vector<ced::any_modality>{ced::make_modality(
                                       "bands(s*):" + std::to_string(ch.threshold) + ",range=0..1")});
      for (std::size_t i = 0; i < c.size(); ++i)
        ASSERT_NEAR(got.saliency[0][i], o.saliency[0][i], 1e-5 * double(bands)) << "point " << i;
      EXPECT_EQ(got.keypoints, o.keypoints);
      EXPECT_GT(got.keypoints.size(), 5u);
    }
    ced::detail::force_generic_kernel(false);
  }
}

// Per-band normalisation: z-score (σ) and percentiles (a robust span).
TEST(Channels, ZscoreAndPercentileRanges) {
  using kind = ced::range_policy::kind;
  EXPECT_EQ(ced::range_policy::parse("zscore").how, kind::zscore);
  const auto q = ced::range_policy::parse("quantile");
  EXPECT_EQ(q.how, kind::percentiles);
  EXPECT_EQ(q.fixed.lo, 2);
  EXPECT_EQ(q.fixed.hi, 98);
  EXPECT_EQ(ced::range_policy::parse("p5..95").fixed.lo, 5);
  for (const char* bad : {"p", "p5", "p50..10", "p-1..50", "p0..101", "pa..b", "z"})
    EXPECT_THROW(ced::range_policy::parse(bad), std::invalid_argument) << bad;

  // 0, 1, ..., 100 in shuffled order, and one outlier in a copy.
  std::vector<double> v(101);
  for (int i = 0; i <= 100; ++i) v[std::size_t(i)] = double((i * 37) % 101);
  const ced::field f("a", ced::scalar_type::float64, v);
  const auto p = ced::resolve_range(f, ced::range_policy::parse("p2..98"));
  EXPECT_DOUBLE_EQ(p.lo, 2.0);
  EXPECT_DOUBLE_EQ(p.hi, 98.0);
  const auto z = ced::resolve_range(f, ced::range_policy::parse("zscore"));
  EXPECT_DOUBLE_EQ(z.lo, 50.0);
  EXPECT_NEAR(z.hi - z.lo, std::sqrt(850.0), 1e-12);  // population σ of 0..100
  std::vector<double> w = v;
  w[7] = 1e6;
  const ced::field g("b", ced::scalar_type::float64, w);
  const auto pg = ced::resolve_range(g, ced::range_policy::parse("quantile"));
  EXPECT_LT(pg.hi - pg.lo, 100.0);  // the outlier does not set the span
  EXPECT_GT(ced::resolve_range(g, ced::range_policy::parse("auto")).hi, 1e5);
  // A tile has no whole cloud's values to take them from: a clear error.
  ced::field tile_field = f;
  tile_field.whole_range = ced::value_range{0, 100};
  EXPECT_THROW(ced::resolve_range(tile_field, ced::range_policy::parse("zscore")), std::invalid_argument);

  // bands(...,range=zscore) measures what bands of the standardised values
  // measures: two bands 1000 times apart in scale weigh alike.
  auto c = ced_test::make_room(3000, 37);
  std::mt19937 rng(9);
  std::normal_distribution<double> u(0.0, 1.0);
  std::vector<double> a(c.size()), b(c.size());
  for (std::size_t i = 0; i < c.size(); ++i) {
    a[i] = 1000.0 * (std::sin(9.0 * c.position(i)[0]) + 0.3 * u(rng));
    b[i] = 5.0 + std::cos(7.0 * c.position(i)[1]) + 0.3 * u(rng);
  }
  const auto standard = [](const std::vector<double>& x) {
    double m = 0, s = 0;
    for (double t : x) m += t;
    m /= double(x.size());
    for (double t : x) s += (t - m) * (t - m);
    s = std::sqrt(s / double(x.size()));
    std::vector<double> out(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) out[i] = x[i] / s;  // the offset cancels in differences
    return out;
  };
  c.add_field("za", ced::scalar_type::float64, standard(a));
  c.add_field("zb", ced::scalar_type::float64, standard(b));
  c.add_field("a", ced::scalar_type::float64, a);
  c.add_field("b", ced::scalar_type::float64, b);
  ced::detect_params dp;
  const auto got =
      ced::detect(c, dp, std::vector<ced::any_modality>{ced::make_modality("bands(a,b):0.2,range=zscore")});
  const auto want =
      ced::detect(c, dp, std::vector<ced::any_modality>{ced::make_modality("bands(za,zb):0.2,range=0..1")});
  for (std::size_t i = 0; i < c.size(); ++i) ASSERT_NEAR(got.saliency[0][i], want.saliency[0][i], 1e-4) << i;
  EXPECT_GT(got.keypoints.size(), 5u);
  // In tiles: the whole cloud's statistics (test_tiled_whole_stats.cpp has more).
  EXPECT_EQ(
      ced::detect_tiled(c, dp, std::vector<ced::any_modality>{ced::make_modality("bands(a,b):0.2,range=zscore")}, 0.3),
      got.keypoints);
}

// Band reduction by PCA: the components' properties, thread counts, L2
// distances kept by all components, and tiles equal to the whole cloud.
TEST(Channels, PrincipalComponentsOfBands) {
  auto c = ced_test::make_room(4000, 41);
  std::mt19937 rng(13);
  std::normal_distribution<double> u(0.0, 1.0);
  const std::size_t d = 12;
  // Two latent factors spread over 12 bands, plus a little noise.
  std::vector<std::vector<double>> v(d, std::vector<double>(c.size()));
  for (std::size_t i = 0; i < c.size(); ++i) {
    const double f1 = std::sin(11.0 * c.position(i)[0]) + 0.2 * u(rng), f2 = std::cos(8.0 * c.position(i)[1]);
    for (std::size_t b = 0; b < d; ++b)
      v[b][i] = 0.3 + 0.2 * f1 * std::cos(0.3 * double(b)) + 0.1 * f2 * std::sin(0.5 * double(b)) + 0.005 * u(rng);
  }
  std::vector<const ced::field*> f;
  for (std::size_t b = 0; b < d; ++b) c.add_field("w" + std::to_string(10 + b), ced::scalar_type::float32, v[b]);
  for (std::size_t b = 0; b < d; ++b) f.push_back(c.find_field("w" + std::to_string(10 + b)));
  const std::vector<double> ones(d, 1.0);
  std::vector<double> lambda;
  const auto all = ced::principal_components(f, ones, d, 1, &lambda);
  ASSERT_EQ(all.size(), c.size() * d);
  // Eigenvalues largest first, summing to the trace; two carry nearly all.
  double trace = 0;
  for (std::size_t b = 0; b < d; ++b) {
    double m = 0, s = 0;
    for (double x : v[b]) m += double(float(x));
    m /= double(c.size());
    for (double x : v[b]) s += (double(float(x)) - m) * (double(float(x)) - m);
    trace += s / double(c.size());
  }
  double sum = 0;
  for (std::size_t k = 0; k < d; ++k) {
    sum += lambda[k];
    if (k > 0) {
      EXPECT_GE(lambda[k - 1], lambda[k]);
    }
  }
  EXPECT_NEAR(sum, trace, 1e-9 * trace);
  EXPECT_GT((lambda[0] + lambda[1]) / trace, 0.99);
  // The components are uncorrelated, with variances the eigenvalues.
  for (std::size_t a = 0; a < 3; ++a)
    for (std::size_t b = 0; b < 3; ++b) {
      double s = 0;
      for (std::size_t i = 0; i < c.size(); ++i) s += double(all[i * d + a]) * double(all[i * d + b]);
      s /= double(c.size());
      EXPECT_NEAR(s, a == b ? lambda[a] : 0.0, 1e-4 * lambda[0]) << a << "," << b;
    }
  // No unit direction has more variance than the first component.
  for (int t = 0; t < 20; ++t) {
    std::vector<double> dir(d);
    double norm = 0;
    for (double& x : dir) {
      x = u(rng);
      norm += x * x;
    }
    double m = 0, s = 0;
    std::vector<double> proj(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) {
      for (std::size_t b = 0; b < d; ++b) proj[i] += double(float(v[b][i])) * dir[b] / std::sqrt(norm);
      m += proj[i];
    }
    m /= double(c.size());
    for (double p : proj) s += (p - m) * (p - m);
    EXPECT_LE(s / double(c.size()), lambda[0] * (1 + 1e-9));
  }
  // Any thread count: the same bits.
  EXPECT_EQ(ced::principal_components(f, ones, 3, 3), ced::principal_components(f, ones, 3, 1));
  // All components under L2: the same distances as the bands themselves
  // (a rotation); fewer components: a spec of its own, checked for errors.
  ced::detect_params p;
  p.threads = 2;
  const auto plain =
      ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(w*):0.02,norm=l2,range=0..1")});
  const auto rotated =
      ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(w*):0.02,norm=l2,range=0..1,pca=12")});
  for (std::size_t i = 0; i < c.size(); ++i) ASSERT_NEAR(rotated.saliency[0][i], plain.saliency[0][i], 2e-6) << i;
  const auto two =
      ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(w*):0.02,norm=l2,range=0..1,pca=2")});
  EXPECT_GT(two.keypoints.size(), 5u);
  EXPECT_THROW(ced::make_modality("bands(w*):0.1,pca=0"), std::invalid_argument);
  EXPECT_THROW(ced::make_modality("bands(w*):0.1,pca=1.5"), std::invalid_argument);
  EXPECT_THROW(ced::detect(c, p, std::vector<ced::any_modality>{ced::make_modality("bands(w1?):0.1,pca=13")}),
               std::invalid_argument);
  EXPECT_EQ(
      ced::detect_tiled(
          c, p, std::vector<ced::any_modality>{ced::make_modality("bands(w*):0.02,norm=l2,range=0..1,pca=2")}, 0.3),
      two.keypoints);
}
