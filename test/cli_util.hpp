// Shared helpers of the CLI test suites (test_cli_*): run a tool with stdout/stderr captured, read a file whole.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

namespace gyro_allan_test {

struct ToolRun {
  int code;             ///< exit code (-1: killed by a signal)
  std::string out, err;
};

inline std::string slurp(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// Number of lines (newline characters) in a tool's output: an error must be one line.
inline int countLines(const std::string& s) {
  int n = 0;
  for (char c : s) n += c == '\n';
  return n;
}

/// Runs a shell command line, capturing its output in files under out_dir.
inline ToolRun runTool(const std::string& args, const std::string& out_dir) {
  const std::string o = out_dir + "/stdout.txt", e = out_dir + "/stderr.txt";
  const int status = std::system((args + " >" + o + " 2>" + e).c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(o), slurp(e)};
}

}  // namespace gyro_allan_test
