#include "fluoro_tracker/imaging/edge_map.h"

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "../test_support.h"
#include "fluoro_tracker/imaging/detector_model.h"

using namespace fluoro_tracker;
using imaging::EdgeMap;

namespace {

const geometry::XrayCamera kCamera(200, 160, 1000.0, 1000.0, 99.5, 79.5);

// The share of each pixel of the camera's image covered by a disc of radius 30.3 px centred at
// (100, 80), by 8x8 supersampling (pixel centres at integer coordinates), CV_64F.
constexpr double kDiscRadius = 30.3;
cv::Mat discCoverage() {
  cv::Mat coverage(160, 200, CV_64F);
  for (int v = 0; v < coverage.rows; ++v) {
    for (int u = 0; u < coverage.cols; ++u) {
      int covered = 0;
      for (int i = 0; i < 8; ++i) {
        for (int j = 0; j < 8; ++j) {
          const double x = u - 0.5 + (i + 0.5) / 8.0 - 100.0;
          const double y = v - 0.5 + (j + 0.5) / 8.0 - 80.0;
          covered += x * x + y * y <= kDiscRadius * kDiscRadius ? 1 : 0;
        }
      }
      coverage.at<double>(v, u) = covered / 64.0;
    }
  }
  return coverage;
}

// The disc dark on a bright background or the reverse, anti-aliased by its coverage.
cv::Mat disc(bool bright_implant, int type = CV_8U) {
  const double inside = bright_implant ? 200.0 : 40.0;
  const double outside = bright_implant ? 40.0 : 200.0;
  const double unit = type == CV_16U ? 256.0 : 1.0;
  cv::Mat image = discCoverage();
  image.forEach<double>(
      [&](double& f, const int*) { f = unit * (f * inside + (1.0 - f) * outside); });
  cv::Mat out;
  image.convertTo(out, type);
  return out;
}

// A metal disc (line integral 6, beyond the display window's end at 3) in tissue whose line
// integral is `left_tissue` left of u = 100 and `right_tissue` right of it, displayed by the
// detector model without noise or scatter (blur 0.8 px before the logarithm, as a detector
// blurs). The disc is clipped to black; tissue near 3 is displayed near black too. `border`:
// also a band of metal along the image's top, 12 px high (a collimator's blade).
cv::Mat clippedDisc(double left_tissue, double right_tissue, bool border = false) {
  cv::Mat line_integral = discCoverage();
  for (int v = 0; v < line_integral.rows; ++v) {
    for (int u = 0; u < line_integral.cols; ++u) {
      const double tissue = u < 100 ? left_tissue : right_tissue;
      // The detector sums what each part of the pixel transmits.
      const double metal = border && v < 12 ? 1.0 : line_integral.at<double>(v, u);
      line_integral.at<double>(v, u) =
          -std::log(metal * std::exp(-6.0) + (1.0 - metal) * std::exp(-tissue));
    }
  }
  imaging::DetectorSettings detector;
  detector.photons_per_pixel = 0.0;
  detector.scatter_strength = 0.0;
  detector.window_max_attenuation = 3.0;
  std::mt19937_64 rng(1);
  return imaging::formRadiograph(line_integral, detector, &rng);
}

// The signed distances of the map at the disc's outline on its left (u < 100) or right side,
// 24 points each, and whether each lies beside clipped grey.
struct OutlineSamples {
  std::vector<double> distances;
  int beside_clipped = 0;
};
OutlineSamples outlineSamples(const EdgeMap& map, bool left) {
  OutlineSamples out;
  for (int k = 0; k < 24; ++k) {
    const double a = (left ? M_PI : 0.0) + (-0.4 + 0.8 * k / 23.0) * M_PI;
    const Eigen::Vector2d normal(std::cos(a), std::sin(a));
    const Eigen::Vector2d pixel = Eigen::Vector2d(100.0, 80.0) + kDiscRadius * normal;
    double d = 0.0;
    double du = 0.0;
    double dv = 0.0;
    EXPECT_TRUE(map.sample(pixel.x(), pixel.y(), &d, &du, &dv));
    out.distances.push_back(d);
    out.beside_clipped += map.besideClippedGrey(pixel, normal) ? 1 : 0;
  }
  return out;
}

}  // namespace

TEST(EdgeMap, SubPixelEdgesLieOnTheBoundaryInEitherPolarityAndBitDepth) {
  for (bool bright : {false, true}) {
    for (int type : {CV_8U, CV_16U}) {
      const EdgeMap map(disc(bright, type), kCamera, imaging::EdgeMapSettings());
      double d = 0.0;
      double du = 0.0;
      double dv = 0.0;
      double sum = 0.0;
      for (int k = 0; k < 32; ++k) {
        const double a = 2.0 * M_PI * k / 32;
        ASSERT_TRUE(map.sample(100 + kDiscRadius * std::cos(a), 80 + kDiscRadius * std::sin(a), &d,
                               &du, &dv));
        EXPECT_LE(std::abs(d), 0.3) << "bright " << bright << " angle " << a;
        sum += d;
      }
      // No systematic shrink or growth: the mean over the circle is well under a pixel.
      EXPECT_LT(std::abs(sum / 32), 0.1) << "bright " << bright;
      // 10 px inside the disc the nearest edge is ~10 px away; the sign says which side of the
      // edge is brighter (positive), and the distance grows away from the edge.
      ASSERT_TRUE(map.sample(120.0, 80.0, &d, &du, &dv));
      EXPECT_NEAR(std::abs(d), kDiscRadius - 20.0, 1.0);
      if (bright) {
        EXPECT_GT(d, 0.0);
        EXPECT_LT(du, -0.5);
      } else {
        EXPECT_LT(d, 0.0);
        EXPECT_GT(du, 0.5);
      }
      // Just outside the disc, the other sign.
      ASSERT_TRUE(map.sample(100.0 + kDiscRadius + 2.0, 80.0, &d, &du, &dv));
      EXPECT_EQ(d > 0.0, !bright);
    }
  }
}

TEST(EdgeMap, RegionAndScaleKeepPixelsConsistentWithTheCamera) {
  const EdgeMap map(disc(false), kCamera, imaging::EdgeMapSettings(), cv::Rect(40, 20, 120, 120),
                    0.5);
  EXPECT_EQ(map.camera().width(), 60);
  EXPECT_EQ(map.camera().height(), 60);
  // The disc's right-most boundary point, projected with the map's camera, is on an edge.
  const Eigen::Vector3d point_on_boundary((100.0 + kDiscRadius - 99.5) / 1000.0,
                                          (80.0 - 79.5) / 1000.0, 1.0);
  Eigen::Vector2d px;
  ASSERT_TRUE(map.camera().project(point_on_boundary, &px));
  double d = 0.0;
  double du = 0.0;
  double dv = 0.0;
  ASSERT_TRUE(map.sample(px.x(), px.y(), &d, &du, &dv));
  EXPECT_LE(std::abs(d), 0.6);  // half resolution
  EXPECT_FALSE(map.sample(-5.0, 10.0, &d, &du, &dv));
  EXPECT_EQ(d, imaging::EdgeMapSettings().max_distance_px);
}

// The distance is worked out per pixel on first use from a grid of edge points; it must be the
// distance to the nearest sub-pixel edge point however far (past the line band), in a map and
// in its copies (which share the pixels worked out), and the dense truncated map must agree.
TEST(EdgeMap, DistanceIsToTheNearestEdgePointFoundByBruteForce) {
  // Two discs' worth of edges: a ring, and a square whose corners give nearest points that
  // jump between edges.
  cv::Mat image = disc(true);
  cv::rectangle(image, cv::Rect(150, 20, 30, 30), cv::Scalar(120), cv::FILLED);
  const imaging::EdgeMapSettings settings;
  const EdgeMap map(image, kCamera, settings);
  std::vector<Eigen::Vector2d> points;
  for (int v = 0; v < map.edges().rows; ++v) {
    for (int u = 0; u < map.edges().cols; ++u) {
      if (map.edges().at<std::uint8_t>(v, u) != 0) points.push_back(map.edgePoint(u, v));
    }
  }
  ASSERT_GT(points.size(), 100u);
  const EdgeMap copy = map;  // sampled first below, then the original reads what it kept
  int checked = 0;
  for (int v = 0; v < map.edges().rows; v += 3) {
    for (int u = 0; u < map.edges().cols; u += 3) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const auto& p : points) nearest = std::min(nearest, (p - Eigen::Vector2d(u, v)).norm());
      double d = 0.0;
      double du = 0.0;
      double dv = 0.0;
      ASSERT_TRUE(copy.sample(u, v, &d, &du, &dv));
      double again = 0.0;
      ASSERT_TRUE(map.sample(u, v, &again, &du, &dv));
      EXPECT_EQ(d, again);
      const double band = settings.line_distance_band_px;
      if (nearest >= 2.0 * band && nearest < settings.max_distance_px) {
        EXPECT_NEAR(std::abs(d), nearest, 1e-4) << "pixel " << u << ", " << v;
        ++checked;
      } else if (nearest >= settings.max_distance_px) {
        EXPECT_EQ(std::abs(d), settings.max_distance_px);
      } else {
        EXPECT_LE(std::abs(d), nearest + 1e-4);  // to the tangent line: never farther
      }
    }
  }
  EXPECT_GT(checked, 1000);
  for (double truncation : {1.0, 3.0, 100.0}) {
    const EdgeMap fresh(image, kCamera, settings);
    const cv::Mat truncated = fresh.unsignedDistance(truncation);
    for (int v = 0; v < truncated.rows; ++v) {
      for (int u = 0; u < truncated.cols; ++u) {
        double d = 0.0;
        double du = 0.0;
        double dv = 0.0;
        map.sample(u, v, &d, &du, &dv);
        ASSERT_NEAR(truncated.at<float>(v, u), std::min(std::abs(d), truncation), 1e-5)
            << "pixel " << u << ", " << v << " truncation " << truncation;
      }
    }
  }
}

// Copies made by unshared() work out their distances alone, so each may be sampled on its own
// thread while the original is sampled on a third: all of them give the distances of a map
// sampled by one thread.
TEST(EdgeMap, UnsharedCopiesSampleOnTheirOwnThreads) {
  const cv::Mat image = disc(false);
  const imaging::EdgeMapSettings settings;
  const EdgeMap map(image, kCamera, settings);
  double d = 0.0;
  double du = 0.0;
  double dv = 0.0;
  map.sample(100.0, 49.0, &d, &du, &dv);  // some pixels worked out before the copies
  std::vector<EdgeMap> copies = {map.unshared(), map.unshared()};
  const auto sample_all = [](const EdgeMap& m, std::vector<double>* out) {
    for (int v = 0; v < m.edges().rows; ++v) {
      for (int u = 0; u < m.edges().cols; ++u) {
        double distance = 0.0;
        double gu = 0.0;
        double gv = 0.0;
        m.sample(u + 0.25, v + 0.5, &distance, &gu, &gv);
        out->push_back(distance);
      }
    }
  };
  std::vector<std::vector<double>> sampled(3);
  std::thread first(sample_all, std::cref(copies[0]), &sampled[0]);
  std::thread second(sample_all, std::cref(copies[1]), &sampled[1]);
  sample_all(map, &sampled[2]);
  first.join();
  second.join();
  std::vector<double> alone;
  sample_all(EdgeMap(image, kCamera, settings), &alone);
  for (const auto& s : sampled) {
    ASSERT_EQ(s.size(), alone.size());
    for (std::size_t k = 0; k < s.size(); ++k) ASSERT_EQ(s[k], alone[k]) << "sample " << k;
  }
}

// A weakly attenuating implant in a low-dose frame: few quanta through the metal make its
// interior far noisier than the background. Here the implant fills the left of the image
// (grey 152 with noise, its rim at u = 99.5) against a clean background of 200. Its outline
// must stay while most of the noise's edges go.
TEST(EdgeMap, EdgesInTheImplantsNoiseAreDroppedAndItsOutlineKept) {
  cv::Mat image(kCamera.height(), kCamera.width(), CV_32F, cv::Scalar(200.0));
  cv::Mat noise(image.size(), CV_32F);
  cv::RNG rng(7);
  rng.fill(noise, cv::RNG::NORMAL, 152.0, 8.0);
  noise(cv::Rect(0, 0, 100, image.rows)).copyTo(image(cv::Rect(0, 0, 100, image.rows)));
  image.convertTo(image, CV_8U);
  const auto interior_edges = [](const EdgeMap& map) {
    return cv::countNonZero(map.edges()(cv::Rect(0, 0, 90, map.edges().rows)));
  };
  imaging::EdgeMapSettings unfiltered;
  unfiltered.min_edge_significance = 0.0;
  const EdgeMap noisy(image, kCamera, unfiltered);
  const EdgeMap filtered(image, kCamera, imaging::EdgeMapSettings());
  const int before = interior_edges(noisy);
  const int after = interior_edges(filtered);
  EXPECT_GT(before, 300);
  // Chains of pure noise that somewhere peak above 3 sd remain (about 1 % of Gaussian noise's
  // gradients do, and Canny joins many pixels into a chain); most go.
  EXPECT_LT(after, before / 3) << before;
  int on_outline = 0;
  for (int v = 10; v < kCamera.height() - 10; ++v) {
    double d = 0.0;
    double du = 0.0;
    double dv = 0.0;
    ASSERT_TRUE(filtered.sample(99.5, v, &d, &du, &dv));
    if (std::abs(d) <= 0.5) ++on_outline;
  }
  EXPECT_GE(on_outline, kCamera.height() - 20 - 4);
}

// A tightly collimated field: the collimator's black reaches into the region with a border far
// stronger than a faint implant's outline. The automatic Canny thresholds follow the region's
// strongest gradients, and the border alone must not set them, or the implant's edges drop out.
TEST(EdgeMap, ACollimatorsBorderDoesNotSetTheThresholds) {
  cv::Mat image;
  disc(false).convertTo(image, CV_8U, 0.25, 150.0);  // the implant 160, the field 200
  cv::circle(image, cv::Point(100, 80), 140, cv::Scalar(255), 80);  // blades beyond 100 px
  image.setTo(cv::Scalar(0), image == 255);
  const auto pointsOnOutline = [&](bool skip_borders) {
    imaging::EdgeMapSettings settings;
    settings.thresholds_skip_saturated_borders = skip_borders;
    const EdgeMap map(image, kCamera, settings);
    int on_outline = 0;
    for (int k = 0; k < 64; ++k) {
      const double a = 2.0 * M_PI * k / 64;
      double d = 0.0;
      double du = 0.0;
      double dv = 0.0;
      EXPECT_TRUE(map.sample(100 + kDiscRadius * std::cos(a), 80 + kDiscRadius * std::sin(a), &d,
                             &du, &dv));
      if (std::abs(d) <= 0.5) ++on_outline;
    }
    return on_outline;
  };
  EXPECT_GE(pointsOnOutline(true), 60);
  EXPECT_LT(pointsOnOutline(false), 32) << "the border does not set the thresholds here: the test "
                                           "shows nothing";
}

// A display window that clips the metal and nearly the tissue beside it (README "Tracking
// quality", the saturated window): on the left the tissue is displayed within a few grey levels
// of black, and the edge the map finds there lies outward of the true outline (the blurred
// intensity crosses the clip before the outline); on the right, bright tissue, it lies on it.
// With the default margin the left's edges are left out and its outline points are beside
// clipped grey; the right's are kept and not beside it.
TEST(EdgeMap, OutlineBesideClippedGreyIsLeftOut) {
  const cv::Mat image = clippedDisc(2.85, 1.0);
  ASSERT_EQ(image.at<std::uint8_t>(80, 100), 0);  // the metal is clipped
  ASSERT_LT(image.at<std::uint8_t>(80, 40), 25);  // the tissue on the left nearly so
  imaging::EdgeMapSettings off;
  off.clipped_grey_margin = 0.0;
  const EdgeMap as_is(image, kCamera, off);
  const EdgeMap map(image, kCamera, imaging::EdgeMapSettings());
  ASSERT_GT(imaging::EdgeMapSettings().clipped_grey_margin, 0.0);

  // Without the margin the left's edges lie outward (negative: on the dark side of the edge).
  const OutlineSamples left_as_is = outlineSamples(as_is, true);
  double mean = 0.0;
  for (double d : left_as_is.distances) mean += d / left_as_is.distances.size();
  EXPECT_LT(mean, -0.4) << "the edge beside near-black tissue is not moved outward";
  EXPECT_EQ(left_as_is.beside_clipped, 0);

  const OutlineSamples left = outlineSamples(map, true);
  for (double d : left.distances) EXPECT_GT(std::abs(d), 1.5);
  EXPECT_EQ(left.beside_clipped, 24);
  for (const EdgeMap* m : {&as_is, &map}) {
    const OutlineSamples right = outlineSamples(*m, false);
    for (double d : right.distances) EXPECT_LT(std::abs(d), 0.5);
    EXPECT_EQ(right.beside_clipped, 0);
  }
}

// What is not a clipped implant: metal whose interior only touches black at scattered pixels
// (noise), and black that reaches the region's border (a collimator's blade). Outline beside
// them is kept.
TEST(EdgeMap, NoisyMetalAndTheFieldsBlackAreNotClippedImplants) {
  // The disc noisy about grey 8 (sd 8) up to its rim, a sixth of its pixels at 0.
  cv::Mat noisy = clippedDisc(2.85, 1.0);
  cv::RNG rng(3);
  for (int v = 0; v < noisy.rows; ++v) {
    for (int u = 0; u < noisy.cols; ++u) {
      if (std::hypot(u - 100.0, v - 80.0) < kDiscRadius - 0.5) {
        noisy.at<std::uint8_t>(v, u) =
            static_cast<std::uint8_t>(std::max(0.0, rng.gaussian(8.0) + 8.0));
      }
    }
  }
  const EdgeMap noisy_map(noisy, kCamera, imaging::EdgeMapSettings());
  EXPECT_EQ(outlineSamples(noisy_map, true).beside_clipped, 0);

  // A blade along the top: its border with the near-black tissue on the left keeps its edges.
  const cv::Mat bladed = clippedDisc(2.85, 1.0, true);
  const EdgeMap map(bladed, kCamera, imaging::EdgeMapSettings());
  int blade_edges = 0;
  int kept = 0;
  for (int u = 5; u < 95; ++u) {
    double d = 0.0;
    double du = 0.0;
    double dv = 0.0;
    ASSERT_TRUE(map.sample(u, 11.5, &d, &du, &dv));
    kept += std::abs(d) < 1.5 ? 1 : 0;
    blade_edges += map.besideClippedGrey(Eigen::Vector2d(u, 11.5), Eigen::Vector2d(0.0, 1.0));
  }
  EXPECT_GT(kept, 80);
  EXPECT_EQ(blade_edges, 0);
  // The disc, inside the region, is still a clipped implant.
  EXPECT_EQ(outlineSamples(map, true).beside_clipped, 24);
}

TEST(EdgeMap, BadImagesNameTheProblem) {
  EXPECT_THROW_WITH(EdgeMap(cv::Mat(), kCamera, imaging::EdgeMapSettings()), "is empty");
  EXPECT_THROW_WITH(EdgeMap(cv::Mat::zeros(100, 100, CV_8U), kCamera, imaging::EdgeMapSettings()),
                    "camera_info says 200x160");
  EXPECT_THROW_WITH(EdgeMap(cv::Mat::zeros(160, 200, CV_32F), kCamera, imaging::EdgeMapSettings()),
                    "8- or 16-bit");
  imaging::EdgeMapSettings negative;
  negative.min_edge_significance = -1.0;
  EXPECT_THROW_WITH(EdgeMap(disc(false), kCamera, negative), "min_edge_significance");
  imaging::EdgeMapSettings whole_range;
  whole_range.clipped_grey_margin = 1.0;
  EXPECT_THROW_WITH(EdgeMap(disc(false), kCamera, whole_range), "clipped_grey_margin");
}

// Edges on a mask are left out: a dark disc's outline under the mask no longer exists in the
// copy, which measures from the edges left (here none: the far distance), while the original
// map is unchanged; a mask of another size is refused.
TEST(EdgeMap, EdgesOnAMaskAreLeftOutOfACopy) {
  const EdgeMap map(disc(false), kCamera, imaging::EdgeMapSettings());
  double d = 0.0, du = 0.0, dv = 0.0;
  // A point on the outline, to the disc's right.
  ASSERT_TRUE(map.sample(100.0 + kDiscRadius, 80.0, &d, &du, &dv));
  EXPECT_LT(std::abs(d), 0.3);
  cv::Mat everything(map.edges().size(), CV_8U, cv::Scalar(255));
  const EdgeMap none = map.withoutEdgesIn(everything);
  EXPECT_EQ(cv::countNonZero(none.edges()), 0);
  ASSERT_TRUE(none.sample(100.0 + kDiscRadius, 80.0, &d, &du, &dv));
  EXPECT_GT(std::abs(d), 10.0);
  // Only the left half masked: the right half's outline is still there, the left half's is not.
  cv::Mat left(map.edges().size(), CV_8U, cv::Scalar(0));
  left(cv::Rect(0, 0, 100, left.rows)).setTo(255);
  const EdgeMap right = map.withoutEdgesIn(left);
  ASSERT_TRUE(right.sample(100.0 + kDiscRadius, 80.0, &d, &du, &dv));
  EXPECT_LT(std::abs(d), 0.3);
  ASSERT_TRUE(right.sample(100.0 - kDiscRadius, 80.0, &d, &du, &dv));
  EXPECT_GT(std::abs(d), 5.0);
  ASSERT_TRUE(map.sample(100.0 - kDiscRadius, 80.0, &d, &du, &dv));
  EXPECT_LT(std::abs(d), 0.3);
  EXPECT_THROW_WITH(map.withoutEdgesIn(cv::Mat(10, 10, CV_32F, cv::Scalar(0))), "CV_8U");
}

TEST(EdgeMap, AMaskOverPartOfTheMapLeavesOutTheSameEdgesAsAMapSizedOne) {
  // The ring and a square: the mask, a disc over the ring's lower right, cuts both.
  cv::Mat image = disc(true);
  cv::rectangle(image, cv::Rect(150, 20, 30, 30), cv::Scalar(120), cv::FILLED);
  const imaging::EdgeMapSettings settings;
  const EdgeMap map(image, kCamera, settings);
  const cv::Point origin(120, 45);
  cv::Mat crop(70, 90, CV_8U, cv::Scalar(0));  // reaches past the map's right edge (200)
  cv::circle(crop, cv::Point(30, 30), 35, cv::Scalar(255), cv::FILLED);
  cv::Mat whole(map.edges().size(), CV_8U, cv::Scalar(0));
  const cv::Rect on_map = cv::Rect(origin, crop.size()) & cv::Rect(cv::Point(), whole.size());
  crop(on_map - origin).copyTo(whole(on_map));
  const EdgeMap from_crop = map.withoutEdgesIn(crop, origin);
  const EdgeMap from_whole = map.withoutEdgesIn(whole);
  EXPECT_EQ(cv::countNonZero(from_crop.edges() != from_whole.edges()), 0);
  // Both outlines lose edges there: the ring's right side and the square's lower edge.
  for (const cv::Rect& part : {cv::Rect(115, 50, 25, 60), cv::Rect(145, 40, 40, 15)}) {
    EXPECT_LT(cv::countNonZero(from_crop.edges()(part)), cv::countNonZero(map.edges()(part)));
  }
  // The edge points left: those whose sub-pixel point does not round onto the mask.
  std::vector<Eigen::Vector2d> kept;
  for (int v = 0; v < map.edges().rows; ++v) {
    for (int u = 0; u < map.edges().cols; ++u) {
      if (map.edges().at<std::uint8_t>(v, u) == 0) continue;
      const Eigen::Vector2d p = map.edgePoint(u, v);
      if (whole.at<std::uint8_t>(static_cast<int>(std::floor(p.y() + 0.5)),
                                 static_cast<int>(std::floor(p.x() + 0.5))) == 0) {
        kept.push_back(p);
      }
    }
  }
  // Every pixel, in the window the crop's copy keeps distances in and outside it: the same
  // distance as the map-sized mask's copy, twice (worked out, then kept), and the distance to
  // the nearest point left where that is a point distance.
  int checked = 0;
  for (int pass = 0; pass < 2; ++pass) {
    for (int v = 0; v < map.edges().rows; ++v) {
      for (int u = 0; u < map.edges().cols; ++u) {
        double d = 0.0, du = 0.0, dv = 0.0, expected = 0.0;
        ASSERT_TRUE(from_crop.sample(u, v, &d, &du, &dv));
        ASSERT_TRUE(from_whole.sample(u, v, &expected, &du, &dv));
        ASSERT_EQ(d, expected) << "pixel " << u << ", " << v;
        if (pass == 1 || (u % 3 != 0) || (v % 3 != 0)) continue;
        double nearest = std::numeric_limits<double>::infinity();
        for (const auto& p : kept) nearest = std::min(nearest, (p - Eigen::Vector2d(u, v)).norm());
        if (nearest >= 2.0 * settings.line_distance_band_px && nearest < settings.max_distance_px) {
          EXPECT_NEAR(std::abs(d), nearest, 1e-4) << "pixel " << u << ", " << v;
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 1000);
}
