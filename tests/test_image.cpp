#include <doctest/doctest.h>

#include <unistd.h>

#include <filesystem>

#include <crumple/gl/image.h>

using namespace crumple::gl;

TEST_CASE("16-bit grey PNG round-trips to within one level") {
  Image img(37, 11, 1);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) img.at(x, y) = (x * 1777 + y * 31) % 65536 / 65535.0f;
  const auto path =
      (std::filesystem::temp_directory_path() / ("crumple_img16_" + std::to_string(::getpid()) + ".png")).string();
  writePng(path, img, 16);
  CHECK(isPng16(path));
  Image back = readPng(path);
  REQUIRE(back.width == 37);
  REQUIRE(back.height == 11);
  REQUIRE(back.channels == 1);
  for (size_t i = 0; i < img.pixels.size(); ++i) CHECK(std::abs(back.pixels[i] - img.pixels[i]) <= 0.5f / 65535.0f);
}

TEST_CASE("reading a file that is not a PNG is an ImageError naming the file") {
  const auto path =
      (std::filesystem::temp_directory_path() / ("crumple_not_png_" + std::to_string(::getpid()) + ".png")).string();
  FILE* f = std::fopen(path.c_str(), "wb");
  std::fputs("hello", f);
  std::fclose(f);
  CHECK_THROWS_WITH_AS(readPng(path), doctest::Contains(path.c_str()), ImageError);
}
