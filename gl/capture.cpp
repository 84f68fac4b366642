#include <crumple/gl/capture.h>

#include <vector>

namespace crumple::gl {

Image readFramebuffer(GLuint framebuffer, int width, int height, int channels) {
  std::vector<unsigned char> rgba(static_cast<size_t>(width) * height * 4);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  Image img(width, height, channels);
  for (int y = 0; y < height; ++y) {
    const int srcRow = height - 1 - y;  // GL rows run bottom-up
    for (int x = 0; x < width; ++x) {
      for (int c = 0; c < channels; ++c) {
        img.at(x, y, c) = rgba[(static_cast<size_t>(srcRow) * width + x) * 4 + c] / 255.0f;
      }
    }
  }
  return img;
}

void captureToPng(GLuint framebuffer, int width, int height, const std::string& path) {
  writePng(path, readFramebuffer(framebuffer, width, height, 3), 8);
}

}  // namespace crumple::gl
