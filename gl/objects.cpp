#include <crumple/gl/objects.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace crumple::gl {

static GLuint makeBuffer() {
  GLuint id = 0;
  glCreateBuffers(1, &id);
  return id;
}

Buffer::Buffer(size_t bytes, const void* data, GLbitfield flags) : GlName(makeBuffer()), size_(bytes) {
  glNamedBufferStorage(id(), static_cast<GLsizeiptr>(bytes ? bytes : 4), data, flags);
}

void Buffer::upload(size_t offset, size_t bytes, const void* data) {
  glNamedBufferSubData(id(), static_cast<GLintptr>(offset), static_cast<GLsizeiptr>(bytes), data);
}

static GLuint makeTexture() {
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_2D, 1, &id);
  return id;
}

Texture2D::Texture2D(int width, int height, GLenum internalFormat, int levels)
    : GlName(makeTexture()), width_(width), height_(height), format_(internalFormat) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("texture size must be positive");
  glTextureStorage2D(id(), levels, internalFormat, width, height);
  setFilter(levels > 1 ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR, GL_LINEAR);
  setWrap(GL_CLAMP_TO_EDGE);
}

Sampler::Sampler(GLenum minFilter, GLenum magFilter, GLenum wrap) {
  GLuint name = 0;
  glCreateSamplers(1, &name);
  static_cast<GlName&>(*this) = GlName(name);
  glSamplerParameteri(name, GL_TEXTURE_MIN_FILTER, static_cast<GLint>(minFilter));
  glSamplerParameteri(name, GL_TEXTURE_MAG_FILTER, static_cast<GLint>(magFilter));
  glSamplerParameteri(name, GL_TEXTURE_WRAP_S, static_cast<GLint>(wrap));
  glSamplerParameteri(name, GL_TEXTURE_WRAP_T, static_cast<GLint>(wrap));
}

Texture2D Texture2D::layerView(const TextureArray& array, int layer) {
  if (layer < 0 || layer >= array.layers()) throw std::out_of_range("texture array layer out of range");
  GLuint view = 0;
  glGenTextures(1, &view);  // a view needs a name never bound: glCreateTextures would give it a target
  glTextureView(view, GL_TEXTURE_2D, array.id(), array.format(), 0, 1, static_cast<GLuint>(layer), 1);
  Texture2D t;
  static_cast<GlName&>(t) = GlName(view);
  t.width_ = array.width();
  t.height_ = array.height();
  t.format_ = array.format();
  t.setFilter(GL_LINEAR, GL_LINEAR);
  t.setWrap(GL_CLAMP_TO_EDGE);
  return t;
}

TextureArray::TextureArray(int width, int height, int layers, GLenum internalFormat)
    : width_(width), height_(height), layers_(layers), format_(internalFormat) {
  if (width <= 0 || height <= 0 || layers <= 0) throw std::invalid_argument("texture array size must be positive");
  GLuint id = 0;
  glCreateTextures(GL_TEXTURE_2D_ARRAY, 1, &id);
  static_cast<GlName&>(*this) = GlName(id);
  glTextureStorage3D(id, 1, internalFormat, width, height, layers);
  glTextureParameteri(id, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  glTextureParameteri(id, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
}

void Texture2D::upload(GLenum format, GLenum type, const void* data, int level) {
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(id(), level, 0, 0, std::max(1, width_ >> level), std::max(1, height_ >> level), format, type,
                      data);
}

void Texture2D::setFilter(GLenum minFilter, GLenum magFilter) {
  glTextureParameteri(id(), GL_TEXTURE_MIN_FILTER, static_cast<GLint>(minFilter));
  glTextureParameteri(id(), GL_TEXTURE_MAG_FILTER, static_cast<GLint>(magFilter));
}

void Texture2D::setWrap(GLenum wrap) {
  glTextureParameteri(id(), GL_TEXTURE_WRAP_S, static_cast<GLint>(wrap));
  glTextureParameteri(id(), GL_TEXTURE_WRAP_T, static_cast<GLint>(wrap));
}

void Texture2D::download(GLenum format, GLenum type, void* data, size_t bytes) const {
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureImage(id(), 0, format, type, static_cast<GLsizei>(bytes), data);
}

static GLuint makeFramebuffer() {
  GLuint id = 0;
  glCreateFramebuffers(1, &id);
  return id;
}

Framebuffer::Framebuffer() : GlName(makeFramebuffer()) {}

void Framebuffer::attachColor(const Texture2D& t, int index) {
  glNamedFramebufferTexture(id(), GL_COLOR_ATTACHMENT0 + static_cast<GLenum>(index), t.id(), 0);
}
void Framebuffer::attachDepth(const Texture2D& t) { glNamedFramebufferTexture(id(), GL_DEPTH_ATTACHMENT, t.id(), 0); }
void Framebuffer::attachColor(const Renderbuffer& r) {
  glNamedFramebufferRenderbuffer(id(), GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r.id());
}
void Framebuffer::attachDepth(const Renderbuffer& r) {
  glNamedFramebufferRenderbuffer(id(), GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r.id());
}

static GLuint makeRenderbuffer() {
  GLuint id = 0;
  glCreateRenderbuffers(1, &id);
  return id;
}

Renderbuffer::Renderbuffer(int width, int height, GLenum internalFormat, int samples) : GlName(makeRenderbuffer()) {
  if (width <= 0 || height <= 0) throw std::invalid_argument("renderbuffer size must be positive");
  glNamedRenderbufferStorageMultisample(id(), samples, internalFormat, width, height);
}

void Framebuffer::checkComplete() const {
  GLenum status = glCheckNamedFramebufferStatus(id(), GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    throw std::runtime_error("framebuffer incomplete: status 0x" + [&] {
      char buf[16];
      std::snprintf(buf, sizeof buf, "%04x", status);
      return std::string(buf);
    }());
  }
}
void Framebuffer::bind() const { glBindFramebuffer(GL_FRAMEBUFFER, id()); }

static GLuint makeVertexArray() {
  GLuint id = 0;
  glCreateVertexArrays(1, &id);
  return id;
}
VertexArray::VertexArray() : GlName(makeVertexArray()) {}

}  // namespace crumple::gl
