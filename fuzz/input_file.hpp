// For the fuzz targets whose reader takes a file name (stores, plans): each input is put in one
// in-memory file (memfd_create) and read back through its name, /proc/self/fd/N. A file on disk
// would cost a truncate and a writeback on every input (ext4 flushes a file truncated and
// rewritten when it is closed), which made those targets several times slower.
#pragma once

#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace dtflop::fuzz {

// Replaces the in-memory file's contents with `data` and returns the name to read it by.
inline const std::string& input_file(const std::uint8_t* data, std::size_t size) {
  static const int fd = ::memfd_create("dtflop_fuzz_input", MFD_CLOEXEC);
  static const std::string name = "/proc/self/fd/" + std::to_string(fd);
  auto fail = [](const char* what) {
    std::perror(what);
    std::abort();  // the harness, not the code under test, failed
  };
  if (fd < 0) fail("memfd_create");
  if (::ftruncate(fd, 0) != 0) fail("ftruncate");
  for (std::size_t done = 0; done < size;) {
    const ssize_t n = ::pwrite(fd, data + done, size - done, static_cast<off_t>(done));
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) fail("pwrite");
    done += static_cast<std::size_t>(n);
  }
  return name;
}

}  // namespace dtflop::fuzz
