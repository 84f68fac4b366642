#include <crumple/gl/program.h>

#include <algorithm>
#include <stdexcept>

namespace crumple::gl {

Program::Program(const std::vector<Stage>& stages) : GlName(glCreateProgram()) {
  std::vector<GLuint> shaders;
  for (const auto& s : stages) {
    label_ += (label_.empty() ? "" : "+") + s.name;
    GLuint sh = glCreateShader(s.type);
    const char* src = s.source.c_str();
    glShaderSource(sh, 1, &src, nullptr);
    glCompileShader(sh);
    GLint ok = 0;
    glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      GLint len = 0;
      glGetShaderiv(sh, GL_INFO_LOG_LENGTH, &len);
      std::string log(static_cast<size_t>(std::max(len, 1)), '\0');
      glGetShaderInfoLog(sh, len, nullptr, log.data());
      glDeleteShader(sh);
      for (GLuint o : shaders) glDeleteShader(o);
      throw std::runtime_error("shader " + s.name + " failed to compile:\n" + log);
    }
    glAttachShader(id(), sh);
    shaders.push_back(sh);
  }
  glLinkProgram(id());
  for (GLuint sh : shaders) {
    glDetachShader(id(), sh);
    glDeleteShader(sh);
  }
  GLint ok = 0;
  glGetProgramiv(id(), GL_LINK_STATUS, &ok);
  if (!ok) {
    GLint len = 0;
    glGetProgramiv(id(), GL_INFO_LOG_LENGTH, &len);
    std::string log(static_cast<size_t>(std::max(len, 1)), '\0');
    glGetProgramInfoLog(id(), len, nullptr, log.data());
    throw std::runtime_error("program " + label_ + " failed to link:\n" + log);
  }
}

void Program::use() const { glUseProgram(id()); }
GLint Program::location(const char* name) const {
  const std::string_view key(name);
  auto found = locations_.find(key);
  if (found == locations_.end()) found = locations_.emplace(std::string(key), glGetUniformLocation(id(), name)).first;
  return found->second;
}

namespace detail {
void setUniform(GLuint p, GLint l, GLsizei n, const float* v) { glProgramUniform1fv(p, l, n, v); }
void setUniform(GLuint p, GLint l, GLsizei n, const int* v) { glProgramUniform1iv(p, l, n, v); }
void setUniform(GLuint p, GLint l, GLsizei n, const GLuint* v) { glProgramUniform1uiv(p, l, n, v); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::vec2* v) { glProgramUniform2fv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::vec3* v) { glProgramUniform3fv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::vec4* v) { glProgramUniform4fv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::ivec2* v) { glProgramUniform2iv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::ivec3* v) { glProgramUniform3iv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::ivec4* v) { glProgramUniform4iv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::uvec2* v) { glProgramUniform2uiv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::uvec3* v) { glProgramUniform3uiv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::uvec4* v) { glProgramUniform4uiv(p, l, n, &v->x); }
void setUniform(GLuint p, GLint l, GLsizei n, const glm::mat3* v) {
  glProgramUniformMatrix3fv(p, l, n, GL_FALSE, &(*v)[0][0]);
}
void setUniform(GLuint p, GLint l, GLsizei n, const glm::mat4* v) {
  glProgramUniformMatrix4fv(p, l, n, GL_FALSE, &(*v)[0][0]);
}
}  // namespace detail

}  // namespace crumple::gl
