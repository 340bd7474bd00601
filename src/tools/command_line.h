#pragma once

#include <iostream>
#include <optional>

#include <boost/program_options.hpp>

namespace fluoro_tracker {
namespace tools {

// Parses a tool's command line into `vm`. With --help it prints the options; a bad command line
// is reported with the options. Returns the exit code when the tool should stop there (0 after
// --help, 2 for a bad command line), or nothing to carry on. --help is honoured before required
// options are checked.
inline std::optional<int> parseCommandLine(
    const char* tool, const boost::program_options::options_description& options, int argc,
    char** argv, boost::program_options::variables_map* vm) {
  namespace po = boost::program_options;
  try {
    po::store(po::parse_command_line(argc, argv, options), *vm);
    if (vm->count("help")) {
      std::cout << options << "\n";
      return 0;
    }
    po::notify(*vm);
  } catch (const po::error& e) {
    std::cerr << tool << ": " << e.what() << "\n" << options << "\n";
    return 2;
  }
  return std::nullopt;
}

}  // namespace tools
}  // namespace fluoro_tracker
