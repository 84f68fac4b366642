// A tiny levelled logger shared by every layer (crumple_core: no dependencies,
// below physics and render alike). Messages go to stderr unless a sink is
// installed; apps install one that honours --quiet.
#pragma once
#include <functional>
#include <sstream>
#include <string>

namespace crumple {

enum class LogLevel { Debug = 0, Info = 1, Warning = 2, Error = 3 };

using LogSink = std::function<void(LogLevel, const std::string&)>;

void setLogSink(LogSink sink);  // nullptr restores the default stderr sink
void setLogLevel(LogLevel minimum);
LogLevel logLevel();
void logMessage(LogLevel level, const std::string& message);

template <typename... Args>
void logf(LogLevel level, const Args&... args) {
  if (level < logLevel()) return;
  std::ostringstream os;
  (os << ... << args);
  logMessage(level, os.str());
}
template <typename... Args>
void logInfo(const Args&... a) {
  logf(LogLevel::Info, a...);
}
template <typename... Args>
void logWarning(const Args&... a) {
  logf(LogLevel::Warning, a...);
}
template <typename... Args>
void logDebug(const Args&... a) {
  logf(LogLevel::Debug, a...);
}
template <typename... Args>
void logError(const Args&... a) {
  logf(LogLevel::Error, a...);
}

}  // namespace crumple
