#include "imaging/overlay/png_encode.hpp"

#include <opencv2/imgcodecs.hpp>

#include <mutex>

namespace brainshift::imaging {

bool encode_png(const cv::Mat& image, std::vector<unsigned char>& bytes) {
  static std::mutex encoder;
  const std::lock_guard<std::mutex> lock(encoder);
  return cv::imencode(".png", image, bytes);
}

}  // namespace brainshift::imaging
