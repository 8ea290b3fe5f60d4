# cmake -DIN=file -DOUT=header -DNAME=kSymbol -P embed_text.cmake
# Writes a header with the file's text as a C++ string constant (the
# dashboard serves shaders/impostor_runtime.glsl from it, so the browser runs
# the very runtime the C++ and Vulkan sides test, also from an install).
file(READ "${IN}" text)
string(FIND "${text}" ")embed\"" clash)
if(NOT clash EQUAL -1)
  message(FATAL_ERROR "${IN} contains the raw-string delimiter )embed\"")
endif()
file(WRITE "${OUT}" "// Generated from ${IN} by embed_text.cmake; do not edit.\n#pragma once\ninline constexpr char ${NAME}[] = R\"embed(${text})embed\";\n")
