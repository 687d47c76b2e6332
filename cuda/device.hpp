// Whether this process can use a CUDA device, and which: the one check every GPU path of
// dtflop (backends, probes, tests) makes before it touches the device. Plain C++; in a build
// without CUDA it says so.
#pragma once

#include <string>

namespace dtflop::cuda {

// Empty when device 0 is usable; otherwise one line saying why not (no driver, no device,
// dtflop built without CUDA), without advice: the caller says what to do instead.
std::string unavailable_reason();
// Name of device 0 ("NVIDIA H200"); empty without a usable device.
std::string device_name();
// Multiprocessors (SMs) of device 0 (132 on an H200); 0 without a usable device.
int device_sms();
// CUDA devices this process sees (CUDA_VISIBLE_DEVICES applies); 0 without a usable device or CUDA.
int device_count();

}  // namespace dtflop::cuda
