// The outputs of a run (shared/design/scene-format.md, "Outputs"): summary.json,
// events.jsonl, heightmaps/ and normalmaps/, written atomically.
#pragma once
#include <map>
#include <string>
#include <vector>

#include "engine/simulation.h"

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
class OutputWriter {
 public:
  static constexpr const char* kMarker = ".crumple-output";
  explicit OutputWriter(const std::string& dir);  // throws SceneError(dir) if dir is unusable
  ~OutputWriter();                                // removes the staging folder if not committed
  const std::string& staging() const { return staging_; }
  void write(Simulation& sim, const std::map<std::string, std::string>& extraSummary = {});
  // With it on, write() also writes export/scene.gltf (engine/gltf_export.h) into the folder.
  void setExportGltf(bool on) { exportGltf_ = on; }
  void commit();
  // Removes the staging folder now (e.g. on SIGINT/SIGTERM; the destructor does the same).
  void abandon();

 private:
  void checkReplaceable(const std::string& dir) const;
  std::string dir_, staging_;
  bool committed_ = false;
  bool exportGltf_ = false;
};

}  // namespace crumple
