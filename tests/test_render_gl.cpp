// GL foundation on the headless context: a triangle drawn offscreen and read back.
#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>

#include "gl_fixture.h"
#include "gl/capture.h"
#include "gl/objects.h"
#include "gl/gpu_timer.h"
#include "render/renderer.h"

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
    CHECK(prog.uniform(name) == glGetUniformLocation(prog.id(), name));
  CHECK(prog.uniform("uA") >= 0);
  CHECK(prog.uniform("uNone") == -1);
  CHECK(prog.uniform("uB[2]") != prog.uniform("uB[0]"));
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
