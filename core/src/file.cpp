#include "mimic/core/file.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

namespace mimic {

Result<std::string> read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return fail(Errc::io_error, path + ": cannot open: " + std::strerror(errno));
  std::ostringstream ss;
  ss << in.rdbuf();
  if (in.bad()) return fail(Errc::io_error, path + ": read failed");
  return std::move(ss).str();
}

Status write_file_atomic(const std::string& path, std::string_view bytes) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    // Errors name the path asked for: the temporary file beside it is ours, not the caller's.
    if (!out) return fail(Errc::io_error, path + ": cannot create: " + std::strerror(errno));
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.flush();
    if (!out) {
      const int e = errno;
      std::remove(tmp.c_str());
      return fail(Errc::io_error, path + ": write failed" + (e ? std::string(": ") + std::strerror(e) : std::string()));
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return fail(Errc::io_error, path + ": cannot rename into place: " + std::strerror(errno));
  }
  return {};
}

}  // namespace mimic
