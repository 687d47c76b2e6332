// Parsing and printing of the quantities users type and read: durations, byte sizes,
// grid sizes, rates.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace dtflop {

// "1ms", "250us", "0.5s", "1e-3" (seconds), "30ns". Throws InputError naming the text.
double parse_duration(std::string_view text, std::string_view what);
// "4KiB", "16MiB", "1GiB", "1000" (bytes), "2MB".
std::int64_t parse_bytes(std::string_view text, std::string_view what);

// The threads to run with for `--threads requested` (0: every hardware thread). Throws InputError
// naming `what` when it asks for more threads than this machine has (creating thousands of threads
// fails or thrashes) or fewer than 0.
int checked_threads(std::int64_t requested, std::string_view what);

struct Size2 {
  std::int64_t x = 0;
  std::int64_t y = 0;
};
// "1000x1000" or "33" (square). Both sides must be in [1, max]. Throws InputError.
Size2 parse_size2(std::string_view text, std::string_view what, std::int64_t max);

std::string format_duration(double seconds);     // "12.3 us", "4.56 ms"
std::string format_bandwidth(double bytes_per_s); // "54.2 GB/s", "4.19 TB/s"
std::string format_rate(double flop_per_s);       // "55.1 TFLOP/s"
std::string format_bytes(double bytes);           // "16 MiB"
// Value in its ParamInfo unit ("B/s", "s", "FLOP/s") formatted for people.
std::string format_quantity(double value, std::string_view unit);

}  // namespace dtflop
