// SPDX-License-Identifier: MIT
// The interactive page (ced/html.hpp): its data read back from the page,
// subsampling, escaping, bad input; and the page drawn in headless Chromium
// (skipped, with the reason, where there is no Chromium).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "ced/ced.hpp"
#include "ced/html.hpp"
#include "ced/io/io.hpp"
#include "core/text.hpp"
#include "file_support.hpp"
#include "test_support.hpp"

// stb, a system header for CMake (its warnings are not ours).
#define STB_IMAGE_IMPLEMENTATION
#include <stb_image.h>

namespace fs = std::filesystem;

namespace {

std::string unbase64(const std::string& s) {
  std::string out;
  if (!ced::detail::base64_decode(s, out)) throw std::runtime_error("the page's data is not base64");
  return out;
}

/// The page's data object (the JSON after "const CED_DATA = ").
nlohmann::json page_data(const std::string& page) {
  const std::string mark = "const CED_DATA = ";
  const auto at = page.find(mark);
  if (at == std::string::npos) throw std::runtime_error("no data in the page");
  const auto end = page.find("};", at);
  return nlohmann::json::parse(page.substr(at + mark.size(), end + 1 - at - mark.size()));
}

template <class T>
std::vector<T> array_of(const nlohmann::json& j) {
  const std::string bytes = unbase64(j.get<std::string>());
  std::vector<T> v(bytes.size() / sizeof(T));
  std::memcpy(v.data(), bytes.data(), v.size() * sizeof(T));
  return v;
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (auto at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

struct detected {
  ced::point_cloud cloud;
  ced::detection_result result;
};

detected room(std::size_t n, std::uint32_t seed) {
  detected d{ced_test::make_room(n, seed, 0.003f), {}};
  ced::detect_params p;
  p.radius = p.nms_radius = 0.06;
  d.result = ced::detect(d.cloud, p, ced::preset("ced6d"));
  return d;
}

}  // namespace

// The page's base64 (core/text.hpp), against RFC 4648's test vectors, and
// what the decoder refuses.
TEST(HtmlPage, Base64IsRfc4648s) {
  const std::pair<const char*, const char*> vectors[] = {{"", ""},
                                                         {"f", "Zg=="},
                                                         {"fo", "Zm8="},
                                                         {"foo", "Zm9v"},
                                                         {"foob", "Zm9vYg=="},
                                                         {"fooba", "Zm9vYmE="},
                                                         {"foobar", "Zm9vYmFy"}};
  for (const auto& [plain, coded] : vectors) {
    std::string text, back;
    ced::detail::base64_append(plain, std::strlen(plain), text);
    EXPECT_EQ(text, coded);
    EXPECT_TRUE(ced::detail::base64_decode(coded, back)) << coded;
    EXPECT_EQ(back, plain);
  }
  std::string out;
  for (const char* bad : {"Zg=", "Zm9#", "Z===", "Zg==Zg==", "Zm=v"})
    EXPECT_FALSE(ced::detail::base64_decode(bad, out)) << bad;
}

TEST(HtmlPage, EmbedsTheCloudTheKeypointsAndTheSaliencies) {
  const detected d = room(3000, 1);
  ASSERT_GT(d.result.keypoints.size(), 5u);
  ced::html_options o;
  o.info = {{"radius", "0.06"}};
  const std::string page = ced::html_page(d.cloud, d.result.keypoints, ced::html_layers(d.result), o);
  // Self-contained: no external script, style or image, and a policy that
  // forbids every request.
  EXPECT_EQ(page.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(page.find("default-src 'none'"), std::string::npos);
  for (const char* external : {"src=\"http", "href=\"http", "src='http", "<link", "import(", "@import"})
    EXPECT_EQ(page.find(external), std::string::npos) << external;
  const auto j = page_data(page);
  EXPECT_EQ(j["total_points"], d.cloud.size());
  EXPECT_EQ(j["stride"], 1);
  EXPECT_FALSE(j.contains("index"));
  EXPECT_EQ(array_of<float>(j["positions"]), d.cloud.positions());
  EXPECT_EQ(array_of<std::uint32_t>(j["keypoints"]), d.result.keypoints);
  ASSERT_EQ(j["modalities"].size(), 2u);
  for (std::size_t m = 0; m < 2; ++m) {
    EXPECT_EQ(j["modalities"][m]["name"], d.result.names[m]);
    EXPECT_DOUBLE_EQ(j["modalities"][m]["threshold"].get<double>(), d.result.thresholds[m]);
    EXPECT_EQ(array_of<float>(j["modalities"][m]["saliency"]), d.result.saliency[m]);
  }
  const auto rgb = array_of<std::uint8_t>(j["rgb"]);
  ASSERT_EQ(rgb.size(), 3 * d.cloud.size());
  for (std::size_t i = 0; i < d.cloud.size(); i += 97)
    EXPECT_EQ(rgb[3 * i], static_cast<std::uint8_t>(d.cloud.get_field("red").values[i] + 0.5)) << i;
  EXPECT_EQ(j["info"][0][0], "radius");
  // Deterministic.
  EXPECT_EQ(ced::html_page(d.cloud, d.result.keypoints, ced::html_layers(d.result), o), page);
}

TEST(HtmlPage, SubsamplesLargeCloudsAndKeepsEveryKeypoint) {
  const detected d = room(4000, 2);
  ced::html_options o;
  o.max_points = 1000;
  const auto j = page_data(ced::html_page(d.cloud, d.result.keypoints, ced::html_layers(d.result), o));
  EXPECT_EQ(j["stride"], 4);
  EXPECT_EQ(j["total_points"], 4000);
  const auto index = array_of<std::uint32_t>(j["index"]);
  EXPECT_LE(index.size(), 1000 + d.result.keypoints.size());
  EXPECT_GE(index.size(), 1000u);
  EXPECT_TRUE(std::is_sorted(index.begin(), index.end()));
  // Every keypoint is drawn, and its display index leads back to it.
  const auto kp = array_of<std::uint32_t>(j["keypoints"]);
  ASSERT_EQ(kp.size(), d.result.keypoints.size());
  for (std::size_t k = 0; k < kp.size(); ++k) EXPECT_EQ(index.at(kp[k]), d.result.keypoints[k]);
  // The drawn positions and saliencies are those of the drawn points.
  const auto pos = array_of<float>(j["positions"]);
  const auto s0 = array_of<float>(j["modalities"][0]["saliency"]);
  for (std::size_t q = 0; q < index.size(); q += 37) {
    EXPECT_EQ(pos[3 * q + 2], d.cloud.position(index[q])[2]);
    EXPECT_EQ(s0[q], d.result.saliency[0][index[q]]);
  }
}

TEST(HtmlPage, EscapesTextAndRejectsBadInput) {
  ced::point_cloud c;
  for (int i = 0; i < 10; ++i) c.push_back(0.1f * i, 0, 0);
  c.push_back(std::nanf(""), 0, 0);  // not drawn
  std::vector<ced::html_layer> layers = {{"</script><b>x</b>", 0.5, std::vector<float>(11, 0.25f)}};
  ced::html_options o;
  o.title = "a \"title\" </script>";
  const std::string page = ced::html_page(c, {1, 3}, layers, o);
  const std::string plain = ced::html_page(c, {1, 3}, {{"x", 0.5, std::vector<float>(11, 0.25f)}});
  EXPECT_EQ(count(page, "</script>"), count(plain, "</script>"));  // only the page's own
  const auto j = page_data(page);
  EXPECT_EQ(j["modalities"][0]["name"], "</script><b>x</b>");
  EXPECT_EQ(j["title"], "a \"title\" </script>");
  EXPECT_EQ(j["total_points"], 10);  // the NaN point is not drawn
  // A layer without a threshold (a cloud written earlier): null.
  const auto unknown = page_data(ced::html_page(c, {}, {{"x", std::nan(""), std::vector<float>(11, 0.f)}}));
  EXPECT_TRUE(unknown["modalities"][0]["threshold"].is_null());
  EXPECT_THROW(ced::html_page(c, {11}, layers), std::invalid_argument);
  EXPECT_THROW(ced::html_page(c, {1}, {{"x", 0.5, std::vector<float>(3, 0.f)}}), std::invalid_argument);
  o.max_points = 0;
  EXPECT_THROW(ced::html_page(c, {1}, layers, o), std::invalid_argument);
  o.max_points = 10;
  o.point_radius.assign(5, 0.1f);  // not one a point
  EXPECT_THROW(ced::html_page(c, {1}, layers, o), std::invalid_argument);
  o.point_radius.clear();
  // An empty cloud is a valid (empty) page.
  EXPECT_NO_THROW(ced::html_page(ced::point_cloud{}, {}, {}));
  // A path that cannot be written: an error, no file.
  EXPECT_THROW(ced::write_html("/nonexistent_dir/x.html", c, {1}, layers), ced::io::io_error);
}

// ---------------------------------------------------------------------------
// In a real browser.

namespace {

std::string chromium_path() {
  if (const char* env = std::getenv("CED_CHROMIUM")) return env;
  for (const char* name : {"chromium", "chromium-browser", "google-chrome"}) {
    const std::string cmd = std::string("command -v ") + name + " 2>/dev/null";
    FILE* p = ::popen(cmd.c_str(), "r");
    if (!p) continue;
    char buf[512] = {};
    const bool found = std::fgets(buf, sizeof buf, p) != nullptr;
    ::pclose(p);
    if (found) {
      std::string s(buf);
      while (!s.empty() && (s.back() == '\n' || s.back() == '\r')) s.pop_back();
      return s;
    }
  }
  return {};
}

/// Runs headless Chromium (software WebGL, no background traffic of its own)
/// on `url` with `extra` arguments; returns its stdout.
std::string run_chromium(const std::string& chromium, const std::string& url, const std::string& extra,
                         const std::string& profile) {
  const std::string cmd = "timeout 120 '" + chromium +
                          "' --headless --no-sandbox --disable-gpu --use-gl=swiftshader --enable-unsafe-swiftshader "
                          "--window-size=1200,900 --virtual-time-budget=8000 --disable-background-networking "
                          "--disable-component-update --disable-sync --no-first-run --disable-default-apps "
                          "--disable-extensions --user-data-dir='" +
                          profile + "' " + extra + " '" + url + "' 2>/dev/null";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) throw std::runtime_error("cannot run " + chromium);
  std::string out;
  char buf[65536];
  std::size_t got;
  while ((got = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, got);
  ::pclose(p);
  return out;
}

/// URLs that the page itself asked for, from Chromium's network log: requests
/// whose isolation key is the file:// page's (Chromium's own requests have
/// none, or their own sites').
std::vector<std::string> page_requests(const std::string& netlog) {
  std::ifstream in(netlog);
  const auto j = nlohmann::json::parse(in);
  const int start_job = j["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"];
  std::vector<std::string> urls;
  for (const auto& e : j["events"]) {
    if (e["type"] != start_job || !e.contains("params")) continue;
    const auto& p = e["params"];
    const std::string key = p.contains("network_isolation_key") && p["network_isolation_key"].is_string()
                                ? p["network_isolation_key"].get<std::string>()
                                : "";
    const std::string initiator =
        p.contains("initiator") && p["initiator"].is_string() ? p["initiator"].get<std::string>() : "";
    if (key.find("file://") != std::string::npos || initiator.find("file://") != std::string::npos)
      urls.push_back(p.value("url", ""));
  }
  return urls;
}

}  // namespace

TEST(HtmlPage, DrawsInHeadlessChromiumWithoutNetwork) {
  const std::string chromium = chromium_path();
  if (chromium.empty())
    GTEST_SKIP() << "Chromium not found (install Debian's `chromium`, or set CED_CHROMIUM): the page is not tested "
                    "in a browser here";
  const fs::path dir = ced_test::temp_dir() / "html_browser";
  fs::create_directories(dir);
  const ced::point_cloud cloud = ced::io::read_cloud(std::string(CED_TEST_DATA_DIR) + "/apartment_mesh_214.ply");
  ced::detect_params p;
  const auto r = ced::detect(cloud, p, ced::preset("ced6d"));
  const std::string page = (dir / "view.html").string();
  ced::write_html(page, cloud, r.keypoints, ced::html_layers(r));

  // The picture: the cloud drawn (pixels unlike the background in the canvas
  // area), and the keypoint markers' colour present.
  const std::string shot = (dir / "shot.png").string();
  run_chromium(chromium, "file://" + page, "--screenshot='" + shot + "'", (dir / "profile1").string());
  int w = 0, h = 0, ch = 0;
  unsigned char* px = stbi_load(shot.c_str(), &w, &h, &ch, 3);
  ASSERT_NE(px, nullptr) << "Chromium wrote no screenshot";
  std::size_t drawn = 0, marker = 0, canvas = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 300; x < w; ++x) {  // right of the side panel
      const unsigned char* q = px + 3 * (std::size_t(y) * w + x);
      ++canvas;
      if (std::abs(q[0] - 30) + std::abs(q[1] - 31) + std::abs(q[2] - 34) > 24) ++drawn;
      if (q[0] > 235 && q[1] > 25 && q[1] < 70 && q[2] > 60 && q[2] < 110) ++marker;
    }
  stbi_image_free(px);
  EXPECT_GT(drawn, canvas / 20) << "the cloud is not drawn: " << drawn << " of " << canvas << " pixels";
  EXPECT_GT(marker, 500u) << "no keypoint markers drawn";

  // The page's own report after running, a point's panel (#pick=), and the
  // network log: no request at all from the page.
  const std::string net = (dir / "net.json").string();
  const std::string dom = run_chromium(chromium, "file://" + page + "#colour=s0&pick=" + std::to_string(r.keypoints[0]),
                                       "--dump-dom --log-net-log='" + net + "'", (dir / "profile2").string());
  EXPECT_NE(dom.find("ready points=24574 keypoints=" + std::to_string(r.keypoints.size())), std::string::npos) << dom;
  EXPECT_NE(dom.find("resources=0"), std::string::npos);
  EXPECT_NE(dom.find("<b>point " + std::to_string(r.keypoints[0]) + "</b>"), std::string::npos);
  EXPECT_NE(dom.find(">keypoint<"), std::string::npos);
  const auto requests = page_requests(net);
  EXPECT_TRUE(requests.empty()) << "the page made a request: " << requests.front();

  // Under a knn neighbourhood, a picked point's panel shows its own radius.
  p.neighborhood = ced::parse_neighborhood("knn:16");
  const auto knn = ced::detect(cloud, p, ced::preset("ced6d"));
  ced::html_options with_radius;
  with_radius.point_radius = knn.point_radius;
  const std::string knn_page = (dir / "knn.html").string();
  ced::write_html(knn_page, cloud, knn.keypoints, ced::html_layers(knn), with_radius);
  const std::uint32_t k0 = knn.keypoints[0];
  char shown[32];
  std::snprintf(shown, sizeof shown, "%.4f", double(knn.point_radius[k0]));
  const std::string knn_dom = run_chromium(chromium, "file://" + knn_page + "#pick=" + std::to_string(k0), "--dump-dom",
                                           (dir / "profile4").string());
  EXPECT_NE(knn_dom.find("<td>own radius</td><td>" + std::string(shown) + "</td>"), std::string::npos) << shown;
  EXPECT_EQ(dom.find("<td>own radius</td><td>0"), std::string::npos) << "a fixed-radius page shows no own radius";

  // The check itself: a page that loads an image and fetches is caught.
  const std::string bad = (dir / "bad.html").string();
  ced_test::write_bytes(bad,
                        "<html><body><img src=\"http://127.0.0.1:9/x.png\">"
                        "<script>fetch('https://example.invalid/a').catch(() => {})</script></body></html>");
  const std::string net_bad = (dir / "net_bad.json").string();
  run_chromium(chromium, "file://" + bad, "--dump-dom --log-net-log='" + net_bad + "'", (dir / "profile3").string());
  EXPECT_GE(page_requests(net_bad).size(), 2u);
}
