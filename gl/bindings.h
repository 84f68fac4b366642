// Binding points as types: a texture unit, an image unit and a shader-storage
// binding are numbers a shader declares (layout(binding = N)); the C++ side
// names each one once (deform/bindings.h, the renderer's) and binds through
// these, so no pass passes a bare number.
#pragma once
#include <epoxy/gl.h>

#include <cstddef>

namespace crumple::gl {

// `unit + k`: the k-th element of a sampler or image array declared at `unit`.
struct TextureUnit {
  GLuint index;
  constexpr TextureUnit operator+(int k) const { return {index + static_cast<GLuint>(k)}; }
  constexpr TextureUnit operator+(size_t k) const { return {index + static_cast<GLuint>(k)}; }
};
struct ImageUnit {
  GLuint index;
  constexpr ImageUnit operator+(int k) const { return {index + static_cast<GLuint>(k)}; }
};
struct StorageBinding {
  GLuint index;
};

// glBindTextureUnit (0: nothing at the unit).
inline void bindTexture(TextureUnit unit, GLuint texture) { glBindTextureUnit(unit.index, texture); }
// glBindSampler: `sampler`'s state over the texture at `unit` (0: the texture's own again).
inline void bindSampler(TextureUnit unit, GLuint sampler) { glBindSampler(unit.index, sampler); }
// Nothing at `count` units from `first` (glBindTextures with no names).
inline void unbindTextures(TextureUnit first, GLsizei count) { glBindTextures(first.index, count, nullptr); }
// glBindImageTexture: level 0 of `texture` (all its layers when `layered`).
inline void bindImage(ImageUnit unit, GLuint texture, GLenum access, GLenum format, bool layered = false) {
  glBindImageTexture(unit.index, texture, 0, layered ? GL_TRUE : GL_FALSE, 0, access, format);
}
// glBindImageTexture: one level of `texture`.
inline void bindImageLevel(ImageUnit unit, GLuint texture, int level, GLenum access, GLenum format) {
  glBindImageTexture(unit.index, texture, level, GL_FALSE, 0, access, format);
}
// glBindBufferBase / glBindBufferRange on GL_SHADER_STORAGE_BUFFER.
inline void bindStorage(StorageBinding binding, GLuint buffer) {
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding.index, buffer);
}
inline void bindStorage(StorageBinding binding, GLuint buffer, GLintptr offset, GLsizeiptr bytes) {
  glBindBufferRange(GL_SHADER_STORAGE_BUFFER, binding.index, buffer, offset, bytes);
}

}  // namespace crumple::gl
