#pragma once
// `sirupp view`: a small desktop client that shows sirupp-viewer's images (VIEWER_IMAGE) in a
// window (OpenCV highgui), for lab PCs with a screen. Keys change the viewer's camera through
// VIEWER_CAMERA. The decoding (image_t -> cv::Mat) is viewer/image_codec.hpp, tested there.

#include <iosfwd>
#include <string>
#include <vector>

namespace sirupp::tools {

extern const char* const kViewAbout;

// Exit 0 when the window is closed (or q / Esc, or --duration ends); 1 without a display or when
// no window can be opened; bad arguments throw core::UsageError (exit 2).
int RunView(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace sirupp::tools
