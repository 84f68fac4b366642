// The outputs of a run (docs/outputs.md): summary.json,
// events.jsonl, heightmaps/ and normalmaps/, written atomically.
#pragma once
#include <map>
#include <string>
#include <vector>

#include <crumple/engine/gltf_export.h>
#include <crumple/engine/simulation.h>

namespace crumple {

// What summary.json and events.jsonl hold, as JSON text (OutputWriter writes
// them; the Python module returns the same).
// summary.json's "bodies": every body's pose, velocities, mass and state now.
std::string bodiesJson(const Simulation& sim);
// summary.json: the run so far (bodies, joints, counts, timings), with `extra` as more string fields.
std::string summaryJson(Simulation& sim, const std::map<std::string, std::string>& extra = {});
// events.jsonl's lines so far, one JSON object each: collisions and joint
// breaks in time order (a collision first at equal times).
std::vector<std::string> eventLines(Simulation& sim);

// Writes the outputs of the contract into `dir`: summary.json, events.jsonl,
// heightmaps/ and normalmaps/ (and whatever is already in `staging`, e.g. frames/).
// Everything goes to a temporary sibling folder first and is renamed into place
// at the end, so a failed run never leaves a folder that looks complete.
// A folder is replaced only when crumple wrote it and nothing else is in it: its
// marker file (kMarker) lists every file crumple wrote there; a folder with any
// other file, or without the marker, is refused before the run starts.
//
// The staging folder, DIR.partial-<pid>-<n>, carries the marker from the start, with its owner: the process id,
// the process's start time and the machine's boot id. A run killed outright (SIGKILL, a crash, a power cut) leaves
// it behind; the next writer to DIR removes such folders once their owner is gone (begin()). A folder without the
// marker, or whose owner still runs (or runs on another machine), is never touched.
class OutputWriter {
 public:
  static constexpr const char* kMarker = ".crumple-output";
  // Checks that dir can be written (throws SceneError(dir) if not); creates nothing yet.
  explicit OutputWriter(const std::string& dir);
  ~OutputWriter();  // removes the staging folder if not committed
  // Removes stale staging folders of DIR (above) and creates this writer's own. write() calls it when needed.
  void begin();
  // The staging folder (empty before begin()).
  const std::string& staging() const { return staging_; }
  void write(Simulation& sim, const std::map<std::string, std::string>& extraSummary = {});
  // With it on, write() also writes export/scene.gltf (engine/gltf_export.h) into the folder; with `animation`
  // (kept by the caller until write()), animated with the bodies' recorded motion.
  void setExportGltf(bool on, const GltfAnimation* animation = nullptr) {
    exportGltf_ = on;
    animation_ = animation;
  }
  void commit();
  // Removes the staging folder now (e.g. on SIGINT/SIGTERM; the destructor does the same).
  void abandon();

 private:
  void checkReplaceable(const std::string& dir) const;
  void removeStaleStaging() const;
  std::string given_, dir_, staging_;
  bool begun_ = false, committed_ = false;
  bool exportGltf_ = false;
  const GltfAnimation* animation_ = nullptr;
};

}  // namespace crumple
