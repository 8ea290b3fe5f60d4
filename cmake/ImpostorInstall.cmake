# `cmake --install` rules: the SDK as a CMake package (find_package(impostor
# CONFIG)), a pkg-config file for the C API, and the three binaries.
#
# Install components (also the Debian packages' contents, cmake/ImpostorPackage.cmake):
#   lib     libimpostor.so.X.Y*, libimpostor_runtime.so.X.Y* (the versioned shared objects)
#   sdk     their libimpostor.so / libimpostor_runtime.so links, public headers, CMake and
#           pkg-config files (install `lib` too: `sdk` alone has links to nothing)
#   server  impostor-server        worker  impostor-worker        cli  impostor
#
# Why shared libraries: the SDK's private dependencies are gRPC, protobuf,
# spdlog and nlohmann_json, none of which appear in a public header. Static
# archives would drag every one of them into the consumer's link (and into
# find_package's find_dependency list, and libimpostor-dev's Depends), and
# would make a game that uses its own protobuf version link two. So the SDK
# ships as shared libraries whose only exported symbols are the C API
# (impostor_*) and the C++ SDK (impostor::sdk::*; cmake/impostor_sdk.map);
# gRPC and protobuf are their DT_NEEDED, private, and the CMake package needs
# only what the headers include (Abseil's Status for the C++ targets, nothing
# for the C API).
#
# Why one library for client, cache and C API: all three contain the
# impostor.v1 protobuf code, and two shared objects each registering the same
# .proto files in libprotobuf's descriptor pool abort at load time. So
# impostor::client, impostor::cache and impostor::c are interface targets
# over the one libimpostor.so (each naming its own header dependencies);
# impostor::runtime is pure math and its own libimpostor_runtime.so, so a
# renderer can use it without any network code; impostor::lod (LOD chain
# loading and level selection) is an interface target over the same library.
include_guard(GLOBAL)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(IMPOSTOR_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/impostor)
set(_impostor_headers_dir ${CMAKE_SOURCE_DIR}/client/include)
set(_impostor_includes
  $<BUILD_INTERFACE:${_impostor_headers_dir}> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
set(_impostor_map ${CMAKE_SOURCE_DIR}/cmake/impostor_sdk.map)
# 0.x: every minor version may change the ABI.
set(_impostor_soversion ${PROJECT_VERSION_MAJOR}.${PROJECT_VERSION_MINOR})
# The runtime package's name follows the SONAME (Debian policy 8.1:
# libimpostor.so.0.1 -> libimpostor0.1).
set(IMPOSTOR_LIB_PACKAGE libimpostor${_impostor_soversion})

if(TARGET impostor_cache AND TARGET impostor_client)
  # libimpostor.so: the C API's one source, plus every object of the client
  # and cache archives (whole-archive: the C++ SDK is exported even where the
  # C API does not call it).
  add_library(impostor_sdk_shared SHARED ${CMAKE_SOURCE_DIR}/client/cache/impostor_c.cc)
  # (Plain linker flags, not $<LINK_LIBRARY:WHOLE_ARCHIVE>: impostor_cache
  # links impostor_client itself, which that feature refuses.)
  target_link_libraries(impostor_sdk_shared PRIVATE
    -Wl,--whole-archive impostor_cache impostor_client -Wl,--no-whole-archive)
  target_include_directories(impostor_sdk_shared PUBLIC ${_impostor_includes})
  target_link_options(impostor_sdk_shared PRIVATE "LINKER:--version-script=${_impostor_map}" "LINKER:--no-undefined")
  set_target_properties(impostor_sdk_shared PROPERTIES
    OUTPUT_NAME impostor EXPORT_NAME impostor
    VERSION ${PROJECT_VERSION} SOVERSION ${_impostor_soversion}
    LINK_DEPENDS ${_impostor_map})

  add_library(impostor_pkg_client INTERFACE)
  target_link_libraries(impostor_pkg_client INTERFACE impostor_sdk_shared absl::status absl::statusor)
  add_library(impostor_pkg_cache INTERFACE)
  target_link_libraries(impostor_pkg_cache INTERFACE impostor_pkg_client Threads::Threads)
  add_library(impostor_pkg_c INTERFACE)
  target_link_libraries(impostor_pkg_c INTERFACE impostor_sdk_shared)
  set_target_properties(impostor_pkg_client PROPERTIES EXPORT_NAME client)
  set_target_properties(impostor_pkg_cache PROPERTIES EXPORT_NAME cache)
  set_target_properties(impostor_pkg_c PROPERTIES EXPORT_NAME c)
  set(_impostor_export_targets impostor_sdk_shared impostor_pkg_client impostor_pkg_cache impostor_pkg_c)
endif()

if(TARGET impostor_runtime AND TARGET impostor_lod_sdk)
  # libimpostor_runtime.so: the SDK's runtime adapters over common/runtime,
  # and the LOD chain's loading and level selection (impostor/lod.h, also
  # free of network code; whole-archive, as nothing here calls it).
  add_library(impostor_runtime_shared SHARED ${CMAKE_SOURCE_DIR}/client/runtime/runtime.cc)
  target_link_libraries(impostor_runtime_shared PRIVATE impostor_runtime
    -Wl,--whole-archive impostor_lod_sdk -Wl,--no-whole-archive)
  target_include_directories(impostor_runtime_shared PUBLIC ${_impostor_includes})
  target_link_options(impostor_runtime_shared PRIVATE "LINKER:--version-script=${_impostor_map}" "LINKER:--no-undefined")
  set_target_properties(impostor_runtime_shared PROPERTIES
    OUTPUT_NAME impostor_runtime EXPORT_NAME runtime
    VERSION ${PROJECT_VERSION} SOVERSION ${_impostor_soversion}
    LINK_DEPENDS ${_impostor_map})
  # impostor::lod: the same library; lod.h's Status types need Abseil.
  add_library(impostor_pkg_lod INTERFACE)
  target_link_libraries(impostor_pkg_lod INTERFACE impostor_runtime_shared absl::status absl::statusor)
  # lod.h takes std::span: a consumer on C++17 gets C++20 for what links it.
  target_compile_features(impostor_pkg_lod INTERFACE cxx_std_20)
  set_target_properties(impostor_pkg_lod PROPERTIES EXPORT_NAME lod)
  list(APPEND _impostor_export_targets impostor_runtime_shared impostor_pkg_lod)
endif()

# The same names inside this build tree, for a project that adds this
# repository with add_subdirectory.
foreach(_pair client:impostor_pkg_client cache:impostor_pkg_cache c:impostor_pkg_c runtime:impostor_runtime_shared
              lod:impostor_pkg_lod)
  string(REPLACE ":" ";" _pair ${_pair})
  list(GET _pair 0 _name)
  list(GET _pair 1 _target)
  if(TARGET ${_target})
    add_library(impostor::${_name} ALIAS ${_target})
  endif()
endforeach()

if(_impostor_export_targets)
  # The versioned shared objects (libimpostor.so.X.Y*) are component `lib`,
  # the runtime package libimpostorX.Y (cmake/ImpostorPackage.cmake); the
  # unversioned .so link a linker needs goes with the headers in `sdk`.
  install(TARGETS ${_impostor_export_targets} EXPORT impostorTargets
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT lib NAMELINK_COMPONENT sdk
    INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(FILES
      ${_impostor_headers_dir}/impostor/client.h
      ${_impostor_headers_dir}/impostor/cache.h
      ${_impostor_headers_dir}/impostor/runtime.h
      ${_impostor_headers_dir}/impostor/lod.h
      ${_impostor_headers_dir}/impostor/impostor_c.h
      ${_impostor_headers_dir}/impostor/log.h
    DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/impostor COMPONENT sdk)
  install(EXPORT impostorTargets NAMESPACE impostor:: FILE impostorTargets.cmake
    DESTINATION ${IMPOSTOR_CMAKE_INSTALL_DIR} COMPONENT sdk)

  configure_package_config_file(${CMAKE_SOURCE_DIR}/cmake/impostorConfig.cmake.in
    ${CMAKE_BINARY_DIR}/cmake/impostorConfig.cmake INSTALL_DESTINATION ${IMPOSTOR_CMAKE_INSTALL_DIR}
    PATH_VARS CMAKE_INSTALL_DATADIR)
  # 0.x: a minor version may break the API, so 0.1 satisfies only 0.1.*.
  write_basic_package_version_file(${CMAKE_BINARY_DIR}/cmake/impostorConfigVersion.cmake
    VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
  install(FILES ${CMAKE_BINARY_DIR}/cmake/impostorConfig.cmake ${CMAKE_BINARY_DIR}/cmake/impostorConfigVersion.cmake
    DESTINATION ${IMPOSTOR_CMAKE_INSTALL_DIR} COMPONENT sdk)

  # impostor.pc finds its prefix relative to itself (${pcfiledir}), so a
  # staged install (cmake --install --prefix, DESTDIR) works unchanged.
  file(RELATIVE_PATH IMPOSTOR_PC_PREFIX_FROM_PCDIR "/p/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/p")
  configure_file(${CMAKE_SOURCE_DIR}/cmake/impostor.pc.in ${CMAKE_BINARY_DIR}/cmake/impostor.pc @ONLY)
  install(FILES ${CMAKE_BINARY_DIR}/cmake/impostor.pc
    DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT sdk)

  # The reference GLSL runtime engines copy or #include (docs/runtime.md),
  # beside the headers whose math it repeats: share/impostor/shaders.
  install(FILES
      ${CMAKE_SOURCE_DIR}/shaders/impostor_runtime.glsl
      ${CMAKE_SOURCE_DIR}/shaders/impostor_crossfade.glsl
      ${CMAKE_SOURCE_DIR}/shaders/impostor_material.glsl
      ${CMAKE_SOURCE_DIR}/shaders/impostor_material_light.glsl
    DESTINATION ${CMAKE_INSTALL_DATADIR}/impostor/shaders COMPONENT sdk)
  # The documents the public headers name (share/doc/impostor).
  install(FILES
      ${CMAKE_SOURCE_DIR}/common/manifest/manifest_format.md
      ${CMAKE_SOURCE_DIR}/client/cache/cache_layout.md
      ${CMAKE_SOURCE_DIR}/docs/runtime.md
      ${CMAKE_SOURCE_DIR}/docs/ktx2.md
    DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/impostor COMPONENT sdk)
endif()

foreach(_pair impostor-server:server impostor-worker:worker impostor:cli)
  string(REPLACE ":" ";" _pair ${_pair})
  list(GET _pair 0 _target)
  list(GET _pair 1 _component)
  if(TARGET ${_target})
    install(TARGETS ${_target} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT ${_component})
  endif()
endforeach()
