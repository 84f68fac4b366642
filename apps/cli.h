// What crumple's programs (crumple-sim, crumple-sandbox, crumple-bench) share on their command lines: the same
// options written once, with the same help, and one way to end on bad input (exit status 2).
#pragma once
#include <CLI/CLI.hpp>

#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <crumple/core/log.h>
#include <crumple/core/version.h>
#include <crumple/engine/overrides.h>

namespace crumple::cli {

// --version: "<program> <version>".
inline void addVersion(CLI::App& app, const std::string& program) {
  app.set_version_flag("--version", program + " " + versionString());
}

// --set KEY=VALUE, repeatable: values of the scene changed before it is checked.
inline CLI::Option* addSets(CLI::App& app, std::vector<std::string>& sets) {
  return app.add_option("--set", sets,
                        "KEY=VALUE: change a value of the scene before it is checked (repeatable). KEY is a key path "
                        "as the errors write it (materials.clay.kappa, bodies[ball].velocity), VALUE is JSON")
      ->allow_extra_args(false);
}

// The --set values as overrides (a malformed one throws SceneError).
inline Overrides overridesOf(const std::vector<std::string>& sets) {
  Overrides overrides;
  for (const std::string& s : sets) overrides.push_back(parseOverride(s));
  return overrides;
}

// --antialias fxaa|msaa|none (`help` says which frames it filters).
inline CLI::Option* addAntialias(CLI::App& app, std::string& value, const std::string& help) {
  return app.add_option("--antialias", value, help)
      ->check(CLI::IsMember({"fxaa", "msaa", "none"}))
      ->capture_default_str();
}

// --quiet, -q: only errors.
inline CLI::Option* addQuiet(CLI::App& app, bool& quiet) { return app.add_flag("--quiet,-q", quiet, "Only errors"); }

// Parses the command line. The exit status where the program ends here (--help, --version: 0; bad input: 2, with
// one line "<program>: error: <what>" on stderr, as every other bad input), else nothing.
inline std::optional<int> parse(CLI::App& app, const std::string& program, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == static_cast<int>(CLI::ExitCodes::Success)) return app.exit(e);  // --help, --version
    std::cerr << program << ": error: " << e.what() << " (" << program << " --help lists the options)\n";
    return 2;  // bad command-line input is bad input: exit 2
  }
  return std::nullopt;
}

}  // namespace crumple::cli
