#pragma once
/// @file
/// @brief PNG encoding in memory (OpenCV), one encoding at a time in the process.

#include <opencv2/core.hpp>

#include <vector>

namespace brainshift::imaging {

/// cv::imencode(".png", image, bytes), serialised by a process-wide mutex: ThreadSanitizer
/// reports a data race inside OpenCV's imgcodecs (a library heap string written by one
/// cv::imencode and read by another) and a lock-order inversion in the GDAL mutexes it takes,
/// when two threads encode at once (`register` writes its two overlays on two threads). An
/// encoding takes tens of ms, so serialising it costs little. Returns false when OpenCV cannot
/// encode the image; throws what cv::imencode throws (cv::Exception).
bool encode_png(const cv::Mat& image, std::vector<unsigned char>& bytes);

}  // namespace brainshift::imaging
