// A linked GLSL program and typed handles to its uniforms. A handle's location
// is looked up once, when the pass that owns the program makes it; setting it
// is then one glProgramUniform call of the handle's type (no lookup by name,
// no current program needed).
#pragma once
#include <epoxy/gl.h>

#include <functional>
#include <glm/glm.hpp>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include <crumple/gl/objects.h>

namespace crumple::gl {

namespace detail {
// glProgramUniform*v of the value's type.
void setUniform(GLuint program, GLint location, GLsizei count, const float* v);
void setUniform(GLuint program, GLint location, GLsizei count, const int* v);
void setUniform(GLuint program, GLint location, GLsizei count, const GLuint* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::vec2* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::vec3* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::vec4* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::ivec2* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::ivec3* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::ivec4* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::uvec2* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::uvec3* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::uvec4* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::mat3* v);
void setUniform(GLuint program, GLint location, GLsizei count, const glm::mat4* v);
}  // namespace detail

// A linked program from embedded GLSL sources. Compile and link logs become
// exceptions that name the shader files.
class Program : public GlName<detail::deleteProgram> {
 public:
  Program() = default;
  struct Stage {
    GLenum type;
    std::string name;    // for messages
    std::string source;  // full source including #version
  };
  explicit Program(const std::vector<Stage>& stages);
  void use() const;
  // glGetUniformLocation's answer, asked once per name (a program's locations are fixed once it is linked);
  // -1 for a uniform the program does not have or does not use (setting it then does nothing).
  GLint location(const char* name) const;

  // Sets the uniform at `location` of this program (count > 1: an array's first `count` elements).
  template <typename T>
  void set(GLint location, const T& value) const {
    detail::setUniform(id(), location, 1, &value);
  }
  template <typename T>
  void set(GLint location, const T* values, GLsizei count) const {
    detail::setUniform(id(), location, count, values);
  }

 private:
  struct NameHash {
    using is_transparent = void;
    size_t operator()(std::string_view s) const { return std::hash<std::string_view>{}(s); }
  };
  std::string label_;
  mutable std::unordered_map<std::string, GLint, NameHash, std::equal_to<>> locations_;
};

// A uniform of type T (float, int, GLuint, glm::vec2..4, ivec2..4, uvec2..4, mat3, mat4) of one program, found
// by name once. It holds the program's GL name: moving the Program keeps it valid; a program replaced by another
// needs new handles.
template <typename T>
class Uniform {
 public:
  Uniform() = default;
  Uniform(const Program& program, const char* name) : program_(program.id()), location_(program.location(name)) {}
  GLint location() const { return location_; }
  void set(const T& value) const { detail::setUniform(program_, location_, 1, &value); }
  // An array uniform's first `count` elements.
  void set(const T* values, GLsizei count) const { detail::setUniform(program_, location_, count, values); }

 private:
  GLuint program_ = 0;
  GLint location_ = -1;
};

}  // namespace crumple::gl
