// GL foundation on the headless context: a triangle drawn offscreen and read back.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>

#include "gl_fixture.h"
#include <crumple/gl/capture.h>
#include <crumple/gl/objects.h>
#include <crumple/gl/gpu_timer.h>
#include <crumple/gl/program.h>
#include <crumple/gl/state.h>
#include <crumple/gl/bindings.h>
#include <crumple/render/renderer.h>

using namespace crumple;
using namespace crumple::gl;
using namespace crumple::render;

TEST_CASE("headless context is OpenGL 4.5 core") {
  auto& ctx = test::glContext();
  GLint major = 0, minor = 0, profile = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  glGetIntegerv(GL_CONTEXT_PROFILE_MASK, &profile);
  MESSAGE(ctx.description());
  CHECK(major * 10 + minor >= 45);
  CHECK((profile & GL_CONTEXT_CORE_PROFILE_BIT) != 0);
}

TEST_CASE("a rendered triangle reads back with the expected pixels") {
  test::glContext();
  const int W = 64, H = 64;
  Texture2D color(W, H, GL_RGBA8);
  Framebuffer fb;
  fb.attachColor(color);
  fb.checkComplete();
  fb.bind();
  glViewport(0, 0, W, H);
  glClearColor(0, 0, 1, 1);
  glClear(GL_COLOR_BUFFER_BIT);

  // A red triangle covering the lower-left half of the viewport (below the diagonal x + y = 0).
  const float verts[] = {-1, -1, 1, 0, 0, 1, -1, 1, 0, 0, -1, 1, 1, 0, 0};
  Buffer vbo(sizeof verts, verts);
  VertexArray vao;
  glVertexArrayVertexBuffer(vao.id(), 0, vbo.id(), 0, 5 * sizeof(float));
  glEnableVertexArrayAttrib(vao.id(), 0);
  glEnableVertexArrayAttrib(vao.id(), 1);
  glVertexArrayAttribFormat(vao.id(), 0, 2, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribFormat(vao.id(), 1, 3, GL_FLOAT, GL_FALSE, 2 * sizeof(float));
  glVertexArrayAttribBinding(vao.id(), 0, 0);
  glVertexArrayAttribBinding(vao.id(), 1, 0);
  Program prog({{GL_VERTEX_SHADER, "flat_color.vert", std::string(renderShader("flat_color.vert"))},
                {GL_FRAGMENT_SHADER, "flat_color.frag", std::string(renderShader("flat_color.frag"))}});
  prog.use();
  glBindVertexArray(vao.id());
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glFinish();

  Image img = readFramebuffer(fb.id(), W, H, 3);
  // Image row 0 is the top. Pixel centre (x, y_gl): inside when x_ndc + y_ndc < 0.
  int wrong = 0;
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) {
      const float xn = (x + 0.5f) / W * 2 - 1;
      const float yn = (H - 1 - y + 0.5f) / H * 2 - 1;
      if (std::abs(xn + yn) < 0.05f) continue;  // skip the edge itself
      const bool inside = xn + yn < 0;
      const float r = img.at(x, y, 0), b = img.at(x, y, 2);
      if (inside ? (r < 0.99f || b > 0.01f) : (r > 0.01f || b < 0.99f)) ++wrong;
    }
  }
  CHECK(wrong == 0);
  // Bottom-left is red, top-right is blue.
  CHECK(img.at(0, H - 1, 0) == doctest::Approx(1.0));
  CHECK(img.at(W - 1, 0, 2) == doctest::Approx(1.0));

  const auto path =
      std::filesystem::temp_directory_path() / ("crumple_triangle_" + std::to_string(::getpid()) + ".png");
  captureToPng(fb.id(), W, H, path.string());
  Image back = readPng(path.string(), 3);
  CHECK(back.width == W);
  CHECK(back.at(0, H - 1, 0) == doctest::Approx(1.0));
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

TEST_CASE("compute shaders and image atomics run") {
  test::glContext();
  const char* src = R"(#version 450 core
layout(local_size_x = 8, local_size_y = 8) in;
layout(r32ui, binding = 0) uniform uimage2D img;
void main() { imageAtomicMax(img, ivec2(0, 0), gl_GlobalInvocationID.x + 100u * gl_GlobalInvocationID.y); }
)";
  Program prog({{GL_COMPUTE_SHADER, "atomic_test.comp", src}});
  Texture2D t(1, 1, GL_R32UI);
  const GLuint zero = 0;
  glClearTexImage(t.id(), 0, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
  glBindImageTexture(0, t.id(), 0, GL_FALSE, 0, GL_READ_WRITE, GL_R32UI);
  prog.use();
  glDispatchCompute(2, 2, 1);
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  GLuint out = 0;
  t.download(GL_RED_INTEGER, GL_UNSIGNED_INT, &out, sizeof out);
  CHECK(out == 15u + 100u * 15u);
}

TEST_CASE("a shader that fails to compile is an exception naming it") {
  test::glContext();
  CHECK_THROWS_WITH_AS(Program({{GL_FRAGMENT_SHADER, "broken.frag", "#version 450 core\nvoid main() { x = 1; }"}}),
                       doctest::Contains("broken.frag"), std::runtime_error);
}

TEST_CASE("a program's uniform locations are the driver's, asked once per name") {
  test::glContext();
  const char* src = R"(#version 450 core
layout(local_size_x = 1) in;
layout(r32ui, binding = 0) uniform uimage2D img;
uniform uint uA;
uniform uint uB[3];
void main() { imageStore(img, ivec2(0, 0), uvec4(uA + uB[0] + uB[2])); }
)";
  Program prog({{GL_COMPUTE_SHADER, "uniforms.comp", src}});
  for (const char* name : {"uA", "uB", "uB[0]", "uB[2]", "uNone", "uA"})
    CHECK(prog.location(name) == glGetUniformLocation(prog.id(), name));
  CHECK(prog.location("uA") >= 0);
  CHECK(prog.location("uNone") == -1);
  CHECK(prog.location("uB[2]") != prog.location("uB[0]"));
}

TEST_CASE("typed uniform handles set each type of a program's uniforms, the program current or not") {
  test::glContext();
  const char* src = R"(#version 450 core
layout(local_size_x = 1) in;
layout(std430, binding = 3) writeonly buffer Out { float uOut[]; };
uniform float uF;
uniform int uI;
uniform uint uU;
uniform vec2 uV2;
uniform vec3 uV3;
uniform vec4 uV4;
uniform ivec2 uI2;
uniform ivec3 uI3;
uniform ivec4 uI4;
uniform uvec4 uU4;
uniform mat3 uM3;
uniform mat4 uM4;
uniform vec4 uArr[3];
void main() {
  float v[] = float[](uF, float(uI), float(uU), uV2.y, uV3.z, uV4.w, float(uI2.y), float(uI3.z), float(uI4.w),
                      float(uU4.x), uM3[2][1], uM4[3][2], uArr[0].x, uArr[2].w);
  for (int k = 0; k < v.length(); ++k) uOut[k] = v[k];
}
)";
  Program prog({{GL_COMPUTE_SHADER, "typed.comp", src}});
  Uniform<float> f(prog, "uF");
  Uniform<int> i(prog, "uI");
  Uniform<GLuint> u(prog, "uU");
  Uniform<glm::vec2> v2(prog, "uV2");
  Uniform<glm::vec3> v3(prog, "uV3");
  Uniform<glm::vec4> v4(prog, "uV4");
  Uniform<glm::ivec2> i2(prog, "uI2");
  Uniform<glm::ivec3> i3(prog, "uI3");
  Uniform<glm::ivec4> i4(prog, "uI4");
  Uniform<glm::uvec4> u4(prog, "uU4");
  Uniform<glm::mat3> m3(prog, "uM3");
  Uniform<glm::mat4> m4(prog, "uM4");
  Uniform<glm::vec4> arr(prog, "uArr");
  Uniform<float> none(prog, "uNone");
  CHECK(none.location() == -1);
  none.set(1.0f);  // does nothing
  glUseProgram(0);  // handles set their own program's uniforms
  f.set(1.5f);
  i.set(-2);
  u.set(3u);
  v2.set({0, 4});
  v3.set({0, 0, 5});
  v4.set({0, 0, 0, 6});
  i2.set({0, 7});
  i3.set({0, 0, 8});
  i4.set({0, 0, 0, 9});
  u4.set({10, 0, 0, 0});
  glm::mat3 a(0.0f);
  a[2][1] = 11;
  m3.set(a);
  glm::mat4 b(0.0f);
  b[3][2] = 12;
  m4.set(b);
  const glm::vec4 elements[3] = {{13, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 14}};
  arr.set(elements, 3);
  Buffer out(14 * sizeof(float), nullptr);
  bindStorage(StorageBinding{3}, out.id());
  prog.use();
  glDispatchCompute(1, 1, 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  float got[14] = {};
  glGetNamedBufferSubData(out.id(), 0, sizeof got, got);
  for (int k = 0; k < 14; ++k) CHECK(got[k] == (k == 0 ? 1.5f : k == 1 ? -2.0f : static_cast<float>(k + 1)));
}

TEST_CASE("a state guard puts back the viewport, framebuffers, program and depth and cull state") {
  test::glContext();
  Framebuffer fbo;
  Texture2D color(4, 4, GL_RGBA8);
  fbo.attachColor(color);
  Program prog({{GL_COMPUTE_SHADER, "empty.comp", "#version 450 core\nlayout(local_size_x = 1) in;\nvoid main() {}\n"}});
  glViewport(1, 2, 3, 4);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glDepthFunc(GL_LEQUAL);
  {
    StateGuard guard;
    glViewport(0, 0, 4, 4);
    fbo.bind();
    prog.use();
    glDisable(GL_DEPTH_TEST);
    glEnable(GL_CULL_FACE);
    glDepthFunc(GL_GREATER);
  }
  GLint viewport[4], framebuffer = -1, program = -1, depthFunc = 0;
  glGetIntegerv(GL_VIEWPORT, viewport);
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &framebuffer);
  glGetIntegerv(GL_CURRENT_PROGRAM, &program);
  glGetIntegerv(GL_DEPTH_FUNC, &depthFunc);
  CHECK(viewport[0] == 1);
  CHECK(viewport[1] == 2);
  CHECK(viewport[2] == 3);
  CHECK(viewport[3] == 4);
  CHECK(framebuffer == 0);
  CHECK(program == 0);
  CHECK(depthFunc == GL_LEQUAL);
  CHECK(glIsEnabled(GL_DEPTH_TEST));
  CHECK(!glIsEnabled(GL_CULL_FACE));
}

TEST_CASE("a GPU timer measures every kept stretch without waiting in the loop, more stretches than slots too") {
  test::glContext();
  // Work the GPU (llvmpipe: the CPU's threads) takes measurable time over: clears of a large texture.
  Texture2D t(1024, 1024, GL_RGBA32F);
  const float value[4] = {1, 2, 3, 4};
  GpuTimer timer(3);
  int kept = 0;
  for (int k = 0; k < 10; ++k) {
    timer.begin();
    for (int r = 0; r < 4; ++r) glClearTexImage(t.id(), 0, GL_RGBA, GL_FLOAT, value);
    const bool keep = k % 3 != 2;
    timer.end(keep);
    kept += keep;
  }
  const double ms = timer.finish();
  CHECK(timer.measured() == static_cast<size_t>(kept));
  CHECK(ms > 0);
  CHECK(timer.ms() == ms);  // nothing left to come back
  // An end without a begin is ignored.
  timer.end();
  CHECK(timer.finish() == ms);
}
