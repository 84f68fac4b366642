// Offscreen capture: reads a framebuffer's colour attachment and writes a PNG.
#pragma once
#include <epoxy/gl.h>

#include <string>

#include <crumple/gl/image.h>

namespace crumple::gl {

// Reads RGBA8 pixels of the given framebuffer (0 = default) into an image with
// row 0 at the top, as a picture is viewed.
Image readFramebuffer(GLuint framebuffer, int width, int height, int channels = 3);
void captureToPng(GLuint framebuffer, int width, int height, const std::string& path);

}  // namespace crumple::gl
