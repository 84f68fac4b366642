#include <crumple/core/log.h>

#include <cstdio>
#include <mutex>

namespace crumple {
namespace {
std::mutex gMutex;
LogSink gSink;
LogLevel gLevel = LogLevel::Info;
const char* levelName(LogLevel l) {
  switch (l) {
    case LogLevel::Debug:
      return "debug";
    case LogLevel::Info:
      return "info";
    case LogLevel::Warning:
      return "warning";
    case LogLevel::Error:
      return "error";
  }
  return "?";
}
}  // namespace

void setLogSink(LogSink sink) {
  std::lock_guard lock(gMutex);
  gSink = std::move(sink);
}
void setLogLevel(LogLevel minimum) { gLevel = minimum; }
LogLevel logLevel() { return gLevel; }

void logMessage(LogLevel level, const std::string& message) {
  if (level < gLevel) return;
  std::lock_guard lock(gMutex);
  if (gSink) {
    gSink(level, message);
  } else {
    std::fprintf(stderr, "crumple %s: %s\n", levelName(level), message.c_str());
  }
}

}  // namespace crumple
