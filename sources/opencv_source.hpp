// The implementations behind open_source() (frame_source.hpp); internal to dtflop_sources.
#pragma once

#include <memory>

#include "sources/frame_source.hpp"

namespace dtflop::sources {

// device, file, images, gst, gphoto2 (opencv_source.cpp).
std::unique_ptr<FrameSource> open_opencv_source(const SourceSpec& spec);
// aravis (aravis_source.cpp; throws InputError where dtflop was built without Aravis).
std::unique_ptr<FrameSource> open_aravis_source(const SourceSpec& spec);

}  // namespace dtflop::sources
