// score_poses: compares tracked poses with reference poses (both poses CSVs, e.g. a tracker's
// output and a simulator's ground truth or a lab's reference) frame by frame, with the
// dissertation's success criterion, and prints the same accuracy line as track_bag.
#include <iostream>
#include <map>
#include <string>
#include <utility>

#include <boost/program_options.hpp>

#include "command_line.h"
#include "fluoro_tracker/input_error.h"
#include "fluoro_tracker/io/poses_csv.h"
#include "fluoro_tracker/registration/pose_error.h"

namespace po = boost::program_options;
using namespace fluoro_tracker;

int main(int argc, char** argv) {
  po::options_description options(
      "score_poses: accuracy of tracked poses against reference poses\n\n"
      "In-plane and along-the-beam errors are taken in the poses' fixed frame, which must be the\n"
      "view's optical frame (z along the beam), as in single-plane trials.\n\nOptions");
  std::string poses_path, truth_path, criterion_name;
  options.add_options()("help,h", "show this help")("poses", po::value(&poses_path)->required(),
                                                    "tracked poses CSV")(
      "truth", po::value(&truth_path)->required(), "reference poses CSV")(
      "criterion", po::value(&criterion_name)->default_value("chapter3"),
      "chapter3 (1 mm, 2/3 deg) or chapter4 (1.5 mm, 3/5 deg)");
  po::variables_map vm;
  if (const auto exit_code = tools::parseCommandLine("score_poses", options, argc, argv, &vm)) {
    return *exit_code;
  }
  try {
    if (criterion_name != "chapter3" && criterion_name != "chapter4") {
      throw InputError("--criterion must be chapter3 or chapter4, not '" + criterion_name + "'");
    }
    std::map<std::pair<int, std::string>, geometry::Pose> estimates;
    for (const auto& r : io::readPosesCsv(poses_path)) estimates[{r.frame, r.bone}] = r.pose;
    std::map<int, std::vector<registration::PoseError>> errors_by_frame;
    int missing = 0;
    for (const auto& r : io::readPosesCsv(truth_path)) {
      const auto it = estimates.find({r.frame, r.bone});
      if (it == estimates.end()) {
        ++missing;
        continue;
      }
      errors_by_frame[r.frame].push_back(
          registration::poseError(it->second, r.pose, geometry::Pose::Identity()));
    }
    registration::AccuracyTally tally(criterion_name == "chapter4"
                                          ? registration::kChapter4Criterion
                                          : registration::kChapter3Criterion);
    for (const auto& [frame, errors] : errors_by_frame) tally.addFrame(errors);
    std::cout << "score_poses: " << tally.summary();
    if (missing > 0) std::cout << "; " << missing << " reference pose(s) have no tracked pose";
    std::cout << "\n";
    return tally.frames() > 0 ? 0 : 1;
  } catch (const InputError& e) {
    std::cerr << "score_poses: error: " << e.what() << "\n";
    return 1;
  }
}
