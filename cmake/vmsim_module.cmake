# The shape of a vmsim module library, shared by the main build (CMakeLists.txt) and the
# sanitizer/fuzzing build (fuzz/CMakeLists.txt), which adds the same module folders.

# Warnings for the project's own targets only.
add_library(vmsim_warnings INTERFACE)
target_compile_options(vmsim_warnings INTERFACE -Wall -Wextra -Wpedantic -Wshadow -Wconversion
                                                -Wno-sign-conversion)
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  # g++ 12 reports false positives on std::string concatenation (GCC bug 105329).
  target_compile_options(vmsim_warnings INTERFACE -Wno-restrict)
endif()

# Each module folder adds one library whose sources are src/*.cpp and whose public headers are
# include/vmsim/<module>/*.hpp. Dependencies point one way (README: "Modules").
function(vmsim_add_module name)
  cmake_parse_arguments(ARG "" "" "DEPENDS;PRIVATE_DEPENDS" ${ARGN})
  file(GLOB sources CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cpp)
  add_library(vmsim_${name} STATIC ${sources})
  add_library(vmsim::${name} ALIAS vmsim_${name})
  target_include_directories(vmsim_${name} PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include)
  target_link_libraries(vmsim_${name} PUBLIC ${ARG_DEPENDS} PRIVATE ${ARG_PRIVATE_DEPENDS}
                                                                    vmsim_warnings)
endfunction()
