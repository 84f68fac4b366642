# crumple as a package: the crumple::<layer> target names, the install rules and the files that let
# other projects find the installed libraries (crumpleConfig.cmake for CMake, crumple.pc for pkg-config).
#
#   cmake --install build --prefix /opt/crumple
#   # in a project: find_package(crumple 0.2 REQUIRED) ... target_link_libraries(app PRIVATE crumple::engine)
#
# Installed: lib/libcrumple_*.a (or .so with BUILD_SHARED_LIBS), the layers' headers under
# include/crumple/<layer>/ (`#include <crumple/physics/world.h>` with -I<prefix>/include),
# lib/cmake/crumple/ and lib/pkgconfig/crumple.pc; with the apps, bin/crumple-sim and bin/crumple-sandbox
# (apps/CMakeLists.txt).

include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

# The libraries, lowest layer first, as folder:target. A target's exported name is its folder's last part
# (crumple::core, crumple::physics, crumple::deform_model, crumple::gl, crumple::render, crumple::deform,
# crumple::engine).
set(CRUMPLE_LIBRARIES core:crumple_core physics:crumple_physics deform/model:crumple_deform_model gl:crumple_gl
  render:crumple_render deform:crumple_deform engine:crumple_engine)
set(CRUMPLE_LIBRARY_TARGETS)
foreach(entry ${CRUMPLE_LIBRARIES})
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 1 target)
  string(REPLACE "crumple_" "" name "${target}")
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${name})
  # The headers need C++20; say so to whoever links them.
  target_compile_features(${target} PUBLIC cxx_std_20)
  # The same names inside a build that adds crumple with add_subdirectory or FetchContent.
  add_library(crumple::${name} ALIAS ${target})
  list(APPEND CRUMPLE_LIBRARY_TARGETS ${target})
endforeach()

if(NOT CRUMPLE_INSTALL)
  return()
endif()

set(CRUMPLE_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/crumple")

# Two export sets, the package's components: `physics` (core, physics, the stress-strain model: GLM and the C++
# library only) and `engine` (gl, render, deform, engine: OpenGL, EGL, epoxy, the mesh and scene libraries).
set(CRUMPLE_PHYSICS_TARGETS crumple_core crumple_physics crumple_deform_model)
set(CRUMPLE_ENGINE_TARGETS ${CRUMPLE_LIBRARY_TARGETS})
list(REMOVE_ITEM CRUMPLE_ENGINE_TARGETS ${CRUMPLE_PHYSICS_TARGETS})
install(TARGETS ${CRUMPLE_PHYSICS_TARGETS} EXPORT crumplePhysicsTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${CRUMPLE_ENGINE_TARGETS} EXPORT crumpleEngineTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
# The installed libraries carry no debug info unless asked (a program linking crumple::physics stays small
# whatever build type made them), and no link-time optimisation sections (CRUMPLE_LTO builds fat objects: what
# is installed is their plain code, which links with any compiler and any GCC version, with LTO or without).
option(CRUMPLE_INSTALL_DEBUG_INFO "Keep debug info in the installed libraries" OFF)
if(CMAKE_STRIP)
  foreach(target ${CRUMPLE_LIBRARY_TARGETS})
    get_target_property(lto ${target} INTERPROCEDURAL_OPTIMIZATION)
    set(strip_args)
    if(NOT CRUMPLE_INSTALL_DEBUG_INFO)
      list(APPEND strip_args --strip-debug)
    endif()
    if(lto)
      list(APPEND strip_args "--remove-section=.gnu.lto_*" "--remove-section=.gnu.debuglto_*")
    endif()
    if(strip_args)
      list(JOIN strip_args "\" \"" strip_joined)
      install(CODE "execute_process(COMMAND \"${CMAKE_STRIP}\" \"${strip_joined}\"
        \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${CMAKE_INSTALL_LIBDIR}/$<TARGET_FILE_NAME:${target}>\")")
    endif()
  endforeach()
endif()

# Headers, each layer's under include/crumple/<folder>/. Internal headers (shared only between a layer's
# own sources) stay out.
foreach(entry ${CRUMPLE_LIBRARIES})
  string(REPLACE ":" ";" parts "${entry}")
  list(GET parts 0 folder)
  file(GLOB headers RELATIVE "${PROJECT_SOURCE_DIR}" CONFIGURE_DEPENDS "${PROJECT_SOURCE_DIR}/${folder}/*.h")
  list(REMOVE_ITEM headers physics/step_context.h physics/stages.h physics/joint_solver.h physics/disjoint_sets.h deform/passes.h
       deform/bindings.h render/renderer_impl.h engine/scene_node.h engine/gltf_check.h)
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/crumple/${folder})
endforeach()
# Generated headers.
install(FILES "${PROJECT_BINARY_DIR}/generated/crumple/core/version.h" DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/crumple/core)

install(EXPORT crumplePhysicsTargets NAMESPACE crumple:: DESTINATION ${CRUMPLE_CMAKE_DIR})
install(EXPORT crumpleEngineTargets NAMESPACE crumple:: DESTINATION ${CRUMPLE_CMAKE_DIR})
configure_package_config_file(cmake/crumpleConfig.cmake.in "${PROJECT_BINARY_DIR}/crumpleConfig.cmake"
  INSTALL_DESTINATION ${CRUMPLE_CMAKE_DIR})
# 0.x: a minor version may break the API, so only the same minor version is compatible.
write_basic_package_version_file("${PROJECT_BINARY_DIR}/crumpleConfigVersion.cmake"
  COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/crumpleConfig.cmake" "${PROJECT_BINARY_DIR}/crumpleConfigVersion.cmake"
  DESTINATION ${CRUMPLE_CMAKE_DIR})

# pkg-config: crumple, every layer, and crumple-physics, the physics component (C++20: compile with -std=c++20 or later). Static libraries need their dependencies on the consumer's link
# line, so they are Requires there; shared ones keep them private.
set(CRUMPLE_PC_REQUIRES "glm epoxy egl opengl zlib nlohmann_json tinygltf")
if(CRUMPLE_WITH_GLFW)
  string(APPEND CRUMPLE_PC_REQUIRES " glfw3")
endif()
if(BUILD_SHARED_LIBS)
  set(CRUMPLE_PC_REQUIRES_PUBLIC "glm epoxy")
  set(CRUMPLE_PC_REQUIRES_PRIVATE "${CRUMPLE_PC_REQUIRES}")
else()
  set(CRUMPLE_PC_REQUIRES_PUBLIC "${CRUMPLE_PC_REQUIRES}")
  set(CRUMPLE_PC_REQUIRES_PRIVATE "")
endif()
# Link order: each library before those it uses.
set(CRUMPLE_PC_LIBS "-lcrumple_engine -lcrumple_deform -lcrumple_render -lcrumple_gl -lcrumple_deform_model -lcrumple_physics -lcrumple_core")
# meshoptimizer (crumple_deform) has no pkg-config module: named on the link line.
string(APPEND CRUMPLE_PC_LIBS " -lmeshoptimizer")
foreach(lib ${CMAKE_DL_LIBS})
  string(APPEND CRUMPLE_PC_LIBS " -l${lib}")
endforeach()
file(RELATIVE_PATH CRUMPLE_PC_TO_PREFIX "/prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/prefix")
string(REGEX REPLACE "/$" "" CRUMPLE_PC_TO_PREFIX "${CRUMPLE_PC_TO_PREFIX}")
configure_file(cmake/crumple.pc.in "${PROJECT_BINARY_DIR}/crumple.pc" @ONLY)
# crumple-physics.pc: the physics component alone (no GL).
configure_file(cmake/crumple-physics.pc.in "${PROJECT_BINARY_DIR}/crumple-physics.pc" @ONLY)
install(FILES "${PROJECT_BINARY_DIR}/crumple.pc" "${PROJECT_BINARY_DIR}/crumple-physics.pc"
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
install(FILES LICENSE DESTINATION ${CMAKE_INSTALL_DATADIR}/doc/crumple)
