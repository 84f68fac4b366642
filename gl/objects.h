// Move-only RAII wrappers for the GL objects crumple uses. They hold a name and
// delete it on destruction; all creation goes through DSA (GL 4.5).
#pragma once
#include <epoxy/gl.h>

#include <cstddef>
#include <utility>
#include <vector>

namespace crumple::gl {

template <void (*Deleter)(GLuint)>
class GlName {
 public:
  GlName() = default;
  explicit GlName(GLuint id) : id_(id) {}
  ~GlName() { reset(); }
  GlName(GlName&& o) noexcept : id_(std::exchange(o.id_, 0)) {}
  GlName& operator=(GlName&& o) noexcept {
    if (this != &o) {
      reset();
      id_ = std::exchange(o.id_, 0);
    }
    return *this;
  }
  GlName(const GlName&) = delete;
  GlName& operator=(const GlName&) = delete;
  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  void reset() {
    if (id_) Deleter(id_);
    id_ = 0;
  }

 private:
  GLuint id_ = 0;
};

namespace detail {
inline void deleteBuffer(GLuint id) { glDeleteBuffers(1, &id); }
inline void deleteTexture(GLuint id) { glDeleteTextures(1, &id); }
inline void deleteFramebuffer(GLuint id) { glDeleteFramebuffers(1, &id); }
inline void deleteVertexArray(GLuint id) { glDeleteVertexArrays(1, &id); }
inline void deleteProgram(GLuint id) { glDeleteProgram(id); }
inline void deleteRenderbuffer(GLuint id) { glDeleteRenderbuffers(1, &id); }
inline void deleteSampler(GLuint id) { glDeleteSamplers(1, &id); }
}  // namespace detail

class Buffer : public GlName<detail::deleteBuffer> {
 public:
  Buffer() = default;
  // Immutable storage of `bytes`, optionally initialised from `data`.
  Buffer(size_t bytes, const void* data, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT);
  template <typename T>
  static Buffer fromVector(const std::vector<T>& v, GLbitfield flags = GL_DYNAMIC_STORAGE_BIT) {
    return Buffer(v.size() * sizeof(T), v.data(), flags);
  }
  void upload(size_t offset, size_t bytes, const void* data);
  size_t size() const { return size_; }

 private:
  size_t size_ = 0;
};

class TextureArray;

class Texture2D : public GlName<detail::deleteTexture> {
 public:
  Texture2D() = default;
  Texture2D(int width, int height, GLenum internalFormat, int levels = 1);
  // A 2D view of one layer of `array` (level 0, its format): the layer's storage under a texture of its own, to
  // sample, attach or read as any 2D texture.
  static Texture2D layerView(const TextureArray& array, int layer);
  int width() const { return width_; }
  int height() const { return height_; }
  GLenum format() const { return format_; }
  void upload(GLenum format, GLenum type, const void* data, int level = 0);
  void setFilter(GLenum minFilter, GLenum magFilter);
  void setWrap(GLenum wrap);
  // Reads level 0 back (for tests, capture and the read-back path).
  void download(GLenum format, GLenum type, void* data, size_t bytes) const;

 private:
  int width_ = 0, height_ = 0;
  GLenum format_ = 0;
};

// Sampling state of its own, bound to a texture unit over the texture's (bindSampler): one texture read two ways.
class Sampler : public GlName<detail::deleteSampler> {
 public:
  Sampler(GLenum minFilter, GLenum magFilter, GLenum wrap);
};

// Layers of one size and format (GL_TEXTURE_2D_ARRAY, one level): a shader reaches any layer through one binding.
class TextureArray : public GlName<detail::deleteTexture> {
 public:
  TextureArray() = default;
  TextureArray(int width, int height, int layers, GLenum internalFormat);
  int width() const { return width_; }
  int height() const { return height_; }
  int layers() const { return layers_; }
  GLenum format() const { return format_; }

 private:
  int width_ = 0, height_ = 0, layers_ = 0;
  GLenum format_ = 0;
};

// A multisampled render target (MSAA colour or depth): drawn into, resolved by a blit, never sampled.
class Renderbuffer : public GlName<detail::deleteRenderbuffer> {
 public:
  Renderbuffer() = default;
  Renderbuffer(int width, int height, GLenum internalFormat, int samples);
};

class Framebuffer : public GlName<detail::deleteFramebuffer> {
 public:
  Framebuffer();
  void attachColor(const Texture2D& t, int index = 0);
  void attachDepth(const Texture2D& t);
  void attachColor(const Renderbuffer& r);
  void attachDepth(const Renderbuffer& r);
  // Throws std::runtime_error naming the status when incomplete.
  void checkComplete() const;
  void bind() const;
};

class VertexArray : public GlName<detail::deleteVertexArray> {
 public:
  VertexArray();
};

}  // namespace crumple::gl
