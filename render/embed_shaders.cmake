# Writes OUTPUT: a C++ source defining one string constant per shader file in SHADERS (the file
# name with '.' replaced by '_', e.g. sphere_vert), so the binary runs from anywhere.
file(WRITE ${OUTPUT} "// Generated from shaders/ by render/embed_shaders.cmake. Do not edit.\n")
file(APPEND ${OUTPUT} "#include \"render/shaders.h\"\nnamespace snowsim::shaders {\n")
foreach(shader ${SHADERS})
  get_filename_component(name ${shader} NAME)
  string(REPLACE "." "_" symbol ${name})
  file(READ ${shader} text)
  file(APPEND ${OUTPUT} "const char* const ${symbol} = R\"glsl(${text})glsl\";\n")
endforeach()
file(APPEND ${OUTPUT} "}  // namespace snowsim::shaders\n")
