// Runs the built `mimic` program for end-to-end tests.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

#include "test_data.h"

namespace mimic::test {

struct Outcome {
  int status = -1;     // exit status, −1 when it did not exit normally
  std::string output;  // stdout, and stderr unless asked to leave it out
};

// `args` is a shell fragment (quote paths). With stdout_only, stderr goes to /dev/null.
inline Outcome run_mimic(const std::string& args, bool stdout_only = false) {
  Outcome r;
  std::string cmd = "'";  // built by appending: GCC 12 warns falsely on chained + (-Wrestrict)
  cmd.append(mimic_binary()).append("' ").append(args).append(stdout_only ? " 2>/dev/null" : " 2>&1");
  FILE* p = ::popen(cmd.c_str(), "r");
  if (!p) return r;
  char buf[4096];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.output.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

}  // namespace mimic::test
