// embed-loop: crumple inside your own game loop. The world steps at a fixed rate whatever the frame rate
// (fixed steps keep the simulation stable and repeatable); each frame draws the bodies at a pose
// interpolated between the last two steps, so motion stays smooth when frames and steps don't line up.
#include <cstdio>
#include <vector>

#include <crumple/physics/world.h>

struct Drawn {  // what your renderer would get for each body: where to draw it
  glm::dvec3 position;
  glm::dquat orientation;
};

int main() {
  crumple::World world;
  crumple::BodyDef ground;
  ground.shape = crumple::makeBox({20, 1, 20});
  ground.origin = {0, -0.5, 0};
  ground.isStatic = true;
  world.addBody(ground);

  // A few crates, each dropped from higher up.
  std::vector<int> crates;
  for (int i = 0; i < 4; ++i) {
    crumple::BodyDef crate;
    crate.shape = crumple::makeBox({0.4, 0.4, 0.4});
    crate.origin = {1.0 * i - 1.5, 1.0 + 0.5 * i, 0};
    crates.push_back(world.addBody(crate));
  }

  const double h = 1.0 / 120;  // the physics step (s)
  double accumulator = 0;
  std::vector<crumple::Pose> previous(world.size()), current(world.size());
  auto snapshot = [&](std::vector<crumple::Pose>& poses) {
    // A body's shape frame (what a mesh is drawn in) sits at origin() turned by q; x is its centre of mass.
    for (size_t i = 0; i < world.size(); ++i) poses[i] = {world.body(i).origin(), world.body(i).q};
  };
  snapshot(previous);
  snapshot(current);

  size_t hits = 0;
  // Your loop. Frame times come from your clock; here a 60 Hz display that stalls now and then.
  for (int frame = 0; frame < 240; ++frame) {
    const double frameSeconds = frame % 50 == 49 ? 0.05 : 1.0 / 60;

    // Input: at frame 120 the player kicks the first crate.
    if (frame == 120) world.setVelocity(crates[0], {3, 4, 0});

    // Physics catches up with the clock in whole steps (at most 8 a frame, so a long stall cannot snowball).
    accumulator += frameSeconds;
    for (int n = 0; accumulator >= h && n < 8; ++n, accumulator -= h) {
      previous = current;
      world.step(h);
      snapshot(current);
      hits += world.events().size();  // collisions of this step (your sounds, sparks, damage)
    }
    if (accumulator > h) accumulator = h;

    // Draw: each body between its last two steps' poses.
    const double alpha = accumulator / h;
    std::vector<Drawn> drawn;
    for (size_t i = 0; i < world.size(); ++i)
      drawn.push_back({glm::mix(previous[i].position, current[i].position, alpha),
                       glm::slerp(previous[i].orientation, current[i].orientation, alpha)});
    if (frame % 60 == 59) {
      std::printf("frame %d, t=%.2f s, %zu hits:", frame + 1, world.time(), hits);
      for (int id : crates) std::printf("  crate %d at (%.2f, %.2f, %.2f)", id, drawn[id].position.x,
                                        drawn[id].position.y, drawn[id].position.z);
      std::printf("\n");
    }
  }
  return 0;
}
