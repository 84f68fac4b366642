// Float images and PNG files (8 or 16 bit, grey/RGB/RGBA). No GL here.
// Texture convention: PNG row r is texture row r (v = (r + 0.5) / height), so a
// map written out and read back lands on the same texels.
#pragma once
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace crumple::gl {

struct ImageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct Image {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<float> pixels;  // row-major, channels interleaved, values in [0, 1]

  Image() = default;
  Image(int w, int h, int c, float fill = 0.0f)
      : width(w), height(h), channels(c), pixels(static_cast<size_t>(w) * h * c, fill) {}
  float& at(int x, int y, int c = 0) { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
  float at(int x, int y, int c = 0) const { return pixels[(static_cast<size_t>(y) * width + x) * channels + c]; }
};

// Writes atomically (temporary file + rename). bitDepth is 8 or 16. Values are
// clamped to [0, 1] and rounded to the nearest level. Throws ImageError.
void writePng(const std::string& path, const Image& image, int bitDepth);
// Encodes to PNG bytes in memory.
std::vector<uint8_t> encodePng(const Image& image, int bitDepth);
// Reads an 8- or 16-bit PNG; `wantChannels` 0 keeps the file's channels.
Image readPng(const std::string& path, int wantChannels = 0);
// True when the file is a 16-bit PNG.
bool isPng16(const std::string& path);

}  // namespace crumple::gl
