// SPDX-License-Identifier: BSD-3-Clause
// PNG files (8-bit RGB, zlib-compressed) for the report pictures of `commerge run`.
#pragma once

#include <string>

#include "core/common/status.hpp"
#include "platform/report/raster_image.hpp"

namespace commerge::platform {

/// Writes `image` as a PNG (colour type 2, bit depth 8, no interlace; each row gets the filter of the five
/// PNG filters with the smallest sum of absolute residuals; IDAT deflated by zlib in chunks of at most
/// 64 KiB). The bytes go to `path` + ".tmp", which is flushed, synced and renamed over `path`, so a crash
/// never leaves a half-written `path`; on any error the temporary file is removed. Errors name the path and
/// the operating system's reason; an empty (0 x 0) image is an invalid argument.
Status WritePng(const std::string& path, const RgbImage& image);

}  // namespace commerge::platform
