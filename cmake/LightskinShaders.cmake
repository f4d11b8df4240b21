# Shader embedding: shaders are real files under <module>/shaders/, compiled into the binary at
# build time so no program depends on its working directory.
#
# lightskin_embed_shaders(<target> NAMESPACE <c++ namespace> FILES <paths relative to CMAKE_CURRENT_SOURCE_DIR>)
# generates a source file defining
#   std::span<const lightskin::gl::EmbeddedFile> <namespace>::embeddedShaders();
# whose names are the paths relative to the shaders/ folder each file is in (<module>/shaders/ or, in gi,
# <module>/<technique>/shaders/); two files with one name are an error.

set(LIGHTSKIN_EMBED_SCRIPT ${CMAKE_CURRENT_LIST_DIR}/EmbedFiles.cmake)

function(lightskin_embed_shaders target)
  cmake_parse_arguments(ARG "" "NAMESPACE" "FILES" ${ARGN})
  set(output ${CMAKE_CURRENT_BINARY_DIR}/${target}_embedded_shaders.cpp)
  set(inputs "")
  set(names "")
  foreach(file IN LISTS ARG_FILES)
    get_filename_component(abs ${file} ABSOLUTE)
    string(REGEX REPLACE "^.*/shaders/" "" name ${abs})
    if(name IN_LIST names)
      message(FATAL_ERROR "lightskin_embed_shaders(${target}): two shaders named ${name}")
    endif()
    list(APPEND inputs ${abs})
    list(APPEND names ${name})
  endforeach()
  string(REPLACE ";" "|" inputs_arg "${inputs}")
  string(REPLACE ";" "|" names_arg "${names}")
  add_custom_command(
    OUTPUT ${output}
    COMMAND ${CMAKE_COMMAND} -DOUTPUT=${output} -DNAMESPACE=${ARG_NAMESPACE}
            "-DINPUTS=${inputs_arg}" "-DNAMES=${names_arg}" -P ${LIGHTSKIN_EMBED_SCRIPT}
    DEPENDS ${inputs} ${LIGHTSKIN_EMBED_SCRIPT}
    COMMENT "Embedding shaders of ${target}"
    VERBATIM)
  target_sources(${target} PRIVATE ${output})
endfunction()
