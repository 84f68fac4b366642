# crumple_embed_shaders(TARGET NAME FILES...)
# crumple_embed_files(TARGET NAME FILES...): the same for any text file, looked up
# through crumple::<NAME>::embeddedFile(name) instead of shaderSource(name).
# Turns GLSL files kept in the source tree into a generated C++ source that
# defines `std::string_view crumple::shaders::<NAME>_<stem>()`-style lookups:
# one function `crumple::shaders::get(name)` per embedding target, keyed by file name.
function(crumple_embed_files target namespace)
  set(CRUMPLE_EMBED_FUNCTION embeddedFile)
  crumple_embed_shaders(${target} ${namespace} ${ARGN})
endfunction()

function(crumple_embed_shaders target namespace)
  if(NOT CRUMPLE_EMBED_FUNCTION)
    set(CRUMPLE_EMBED_FUNCTION shaderSource)
  endif()
  string(REPLACE "::" "_" stem "${namespace}")
  set(out_cpp "${CMAKE_CURRENT_BINARY_DIR}/${stem}_embedded.cpp")
  set(files ${ARGN})
  set(abs_files)
  foreach(f ${files})
    list(APPEND abs_files "${CMAKE_CURRENT_SOURCE_DIR}/${f}")
  endforeach()
  string(REPLACE ";" "|" files_arg "${abs_files}")
  add_custom_command(
    OUTPUT "${out_cpp}"
    COMMAND ${CMAKE_COMMAND} -DOUT=${out_cpp} -DNS=${namespace} -DFN=${CRUMPLE_EMBED_FUNCTION} "-DFILES=${files_arg}"
            -P "${PROJECT_SOURCE_DIR}/cmake/EmbedShadersRun.cmake"
    DEPENDS ${abs_files} "${PROJECT_SOURCE_DIR}/cmake/EmbedShadersRun.cmake"
    COMMENT "Embedding ${namespace} shaders"
    VERBATIM)
  target_sources(${target} PRIVATE "${out_cpp}")
endfunction()
