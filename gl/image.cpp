#include <crumple/gl/image.h>

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#define STB_IMAGE_IMPLEMENTATION
#define STBI_ONLY_PNG
#include <stb/stb_image.h>

namespace crumple::gl {

namespace {
void put32(std::vector<uint8_t>& out, uint32_t v) {
  out.push_back(static_cast<uint8_t>(v >> 24));
  out.push_back(static_cast<uint8_t>(v >> 16));
  out.push_back(static_cast<uint8_t>(v >> 8));
  out.push_back(static_cast<uint8_t>(v));
}
void chunk(std::vector<uint8_t>& out, const char* type, const std::vector<uint8_t>& data) {
  put32(out, static_cast<uint32_t>(data.size()));
  const size_t start = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  uLong crc = crc32(0L, Z_NULL, 0);
  crc = crc32(crc, out.data() + start, static_cast<uInt>(out.size() - start));
  put32(out, static_cast<uint32_t>(crc));
}
}  // namespace

std::vector<uint8_t> encodePng(const Image& image, int bitDepth) {
  if (bitDepth != 8 && bitDepth != 16) throw ImageError("PNG bit depth must be 8 or 16");
  if (image.width <= 0 || image.height <= 0 || image.channels < 1 || image.channels > 4 ||
      image.pixels.size() != static_cast<size_t>(image.width) * image.height * image.channels) {
    throw ImageError("malformed image");
  }
  const int bytesPerSample = bitDepth / 8;
  const size_t rowBytes = static_cast<size_t>(image.width) * image.channels * bytesPerSample;
  std::vector<uint8_t> raw;
  raw.reserve((rowBytes + 1) * image.height);
  const float maxLevel = bitDepth == 16 ? 65535.0f : 255.0f;
  for (int y = 0; y < image.height; ++y) {
    raw.push_back(0);  // filter: none
    for (int x = 0; x < image.width; ++x) {
      for (int c = 0; c < image.channels; ++c) {
        float v = image.at(x, y, c);
        if (!(v >= 0.0f)) v = 0.0f;  // NaN -> 0
        v = std::min(v, 1.0f);
        const auto q = static_cast<uint32_t>(v * maxLevel + 0.5f);  // v in [0, 1]: round half up
        if (bitDepth == 16) raw.push_back(static_cast<uint8_t>(q >> 8));
        raw.push_back(static_cast<uint8_t>(q & 0xff));
      }
    }
  }
  uLongf zlen = compressBound(static_cast<uLong>(raw.size()));
  std::vector<uint8_t> z(zlen);
  if (compress2(z.data(), &zlen, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK) {
    throw ImageError("zlib compression failed");
  }
  z.resize(zlen);

  static const uint8_t kSignature[8] = {137, 80, 78, 71, 13, 10, 26, 10};
  std::vector<uint8_t> out(kSignature, kSignature + 8);
  std::vector<uint8_t> ihdr;
  put32(ihdr, static_cast<uint32_t>(image.width));
  put32(ihdr, static_cast<uint32_t>(image.height));
  static const uint8_t kColorType[5] = {0, 0, 4, 2, 6};  // grey, grey+alpha, RGB, RGBA
  ihdr.push_back(static_cast<uint8_t>(bitDepth));
  ihdr.push_back(kColorType[image.channels]);
  ihdr.push_back(0);
  ihdr.push_back(0);
  ihdr.push_back(0);
  chunk(out, "IHDR", ihdr);
  chunk(out, "IDAT", z);
  chunk(out, "IEND", {});
  return out;
}

void writePng(const std::string& path, const Image& image, int bitDepth) {
  const std::vector<uint8_t> bytes = encodePng(image, bitDepth);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw ImageError(path + ": cannot open for writing");
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    if (!f) throw ImageError(path + ": write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw ImageError(path + ": " + ec.message());
}

bool isPng16(const std::string& path) { return stbi_is_16_bit(path.c_str()) != 0; }

Image readPng(const std::string& path, int wantChannels) {
  int w = 0, h = 0, c = 0;
  if (!stbi_info(path.c_str(), &w, &h, &c)) {
    const char* why = stbi_failure_reason();
    throw ImageError(path + ": not a readable PNG (" + (why ? why : "unknown") + ")");
  }
  if (w <= 0 || h <= 0 || w > 16384 || h > 16384) throw ImageError(path + ": image size out of range");
  const int channels = wantChannels ? wantChannels : c;
  Image img(w, h, channels);
  if (stbi_is_16_bit(path.c_str())) {
    stbi_us* data = stbi_load_16(path.c_str(), &w, &h, &c, channels);
    if (!data) throw ImageError(path + ": decoding failed (" + std::string(stbi_failure_reason()) + ")");
    for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = data[i] / 65535.0f;
    stbi_image_free(data);
  } else {
    stbi_uc* data = stbi_load(path.c_str(), &w, &h, &c, channels);
    if (!data) throw ImageError(path + ": decoding failed (" + std::string(stbi_failure_reason()) + ")");
    for (size_t i = 0; i < img.pixels.size(); ++i) img.pixels[i] = data[i] / 255.0f;
    stbi_image_free(data);
  }
  return img;
}

}  // namespace crumple::gl
