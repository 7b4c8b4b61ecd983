// The main() of a bench tool: runs it, reports an error as "NAME: message" on stderr (with the
// usage after a usage error) and turns it into the exit code: 0 done, 2 usage, 1 anything else.
#pragma once

#include <cstdio>
#include <exception>

#include "base/errors.hpp"

namespace palp::bench {

inline int bench_main(const char* name, const char* usage, int (*run)(int, char**), int argc,
                      char** argv) {
  try {
    return run(argc, argv);
  } catch (const UsageError& e) {
    std::fprintf(stderr, "%s: %s\n%s", name, e.what(), usage);
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name, e.what());
    return 1;
  }
}

}  // namespace palp::bench
