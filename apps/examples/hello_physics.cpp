// hello-physics: drop a box on the ground and print where it comes to rest.
#include <cmath>
#include <cstdio>

#include <crumple/core/version.h>
#include <crumple/physics/world.h>

int main() {
  crumple::World world;  // gravity -9.81 m/s^2 along y

  // The ground: a static 20 x 1 x 20 m slab whose top face is at y = 0.
  crumple::BodyDef ground;
  ground.shape = crumple::makeBox({20, 1, 20});
  ground.origin = {0, -0.5, 0};
  ground.isStatic = true;
  world.addBody(ground);

  // A 0.5 m box, 2 m up, tipped a little so that it lands on an edge first.
  const double size = 0.5;
  crumple::BodyDef box;
  box.shape = crumple::makeBox({size, size, size});
  box.origin = {0, 2, 0};
  box.orientation = glm::angleAxis(0.3, glm::normalize(glm::dvec3(1, 0, 1)));
  box.density = 500;  // kg/m^3
  const int id = world.addBody(box);

  const double h = 1.0 / 240;  // s per step
  for (int step = 1; step <= 3 * 240; ++step) {
    world.step(h);
    if (step % 60 == 0) {
      const crumple::RigidBody& b = world.body(id);
      std::printf("t = %.2f s  height %.4f m  speed %.4f m/s%s\n", world.time(), b.x.y, glm::length(b.v),
                  b.asleep ? "  (asleep)" : "");
    }
  }

  // At rest on a face, the box's centre is half its size above the ground.
  const double rest = world.body(id).x.y;
  std::printf("crumple %s: the box rests at %.4f m (half its size: %.4f m)\n", crumple::versionString(), rest,
              size / 2);
  return std::abs(rest - size / 2) < 0.01 ? 0 : 1;
}
