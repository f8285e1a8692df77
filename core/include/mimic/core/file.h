// Whole-file reading and atomic writing: a file is either fully written or left untouched.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "mimic/core/result.h"

namespace mimic {

Result<std::string> read_file(const std::string& path);

// Writes to "<path>.tmp" then renames over path, so readers never see half a file.
Status write_file_atomic(const std::string& path, std::string_view bytes);

}  // namespace mimic
