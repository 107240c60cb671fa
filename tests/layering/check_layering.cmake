# The layering rules, checked on the sources (cmake -P, run by ctest as layering_test):
#  1. daemon/ is the composition root: no file outside server/daemon/ includes "daemon/...".
#  2. A capability's folder (server/<capability>/) includes no other capability's service (a request
#     translator may use another's when its proto imports that one's messages: eWave's ambient ocean).
#  3. The engine library links no gRPC or protobuf (ENGINE_LINKS, computed at configure time), and none of
#     its sources (ENGINE_SOURCES) includes a gRPC, protobuf or RPC-layer header.
# Arguments: -DSOURCE_DIR=... -DENGINE_SOURCES=<file listing sources> -DENGINE_LINKS=<file listing links>
set(violations "")

file(GLOB_RECURSE all_files RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/server/*.h ${SOURCE_DIR}/server/*.cpp ${SOURCE_DIR}/client/*.h ${SOURCE_DIR}/client/*.cpp
     ${SOURCE_DIR}/bench/*.h ${SOURCE_DIR}/bench/*.cpp ${SOURCE_DIR}/tests/*.h ${SOURCE_DIR}/tests/*.cpp)
file(GLOB capability_dirs LIST_DIRECTORIES true RELATIVE ${SOURCE_DIR}/server ${SOURCE_DIR}/server/*)
set(capabilities "")
foreach(dir ${capability_dirs})
  if(EXISTS ${SOURCE_DIR}/server/${dir}/CMakeLists.txt)
    list(APPEND capabilities ${dir})
  endif()
endforeach()

foreach(f ${all_files})
  file(STRINGS ${SOURCE_DIR}/${f} includes REGEX "^#include \"")
  if(NOT f MATCHES "^server/daemon/" AND includes MATCHES "#include \"daemon/")
    list(APPEND violations "${f} includes daemon/ (the composition root)")
  endif()
  foreach(cap ${capabilities})
    if(f MATCHES "^server/${cap}/")
      foreach(other ${capabilities})
        if(NOT other STREQUAL cap AND includes MATCHES "#include \"${other}/[a-z_]*_service\\.h\"")
          list(APPEND violations "${f} includes the ${other} capability's service")
        endif()
      endforeach()
    endif()
  endforeach()
endforeach()

file(STRINGS ${ENGINE_LINKS} links)
foreach(link ${links})
  if(link MATCHES "grpc|protobuf|squall_proto|squall_rpc")
    list(APPEND violations "squall_engine links ${link}")
  endif()
endforeach()
file(STRINGS ${ENGINE_SOURCES} sources)
foreach(source ${sources})
  file(STRINGS ${source} includes REGEX "^#include")
  if(includes MATCHES "grpcpp/|\\.pb\\.h|\"rpc/|_service\\.h|_request\\.h")
    list(APPEND violations "engine source ${source} includes a gRPC, protobuf or RPC-layer header")
  endif()
endforeach()

list(LENGTH all_files checked)
list(LENGTH sources engine_count)
if(violations)
  list(JOIN violations "\n  " text)
  message(FATAL_ERROR "layering violations:\n  ${text}")
endif()
message(STATUS "layering: ${checked} files and ${engine_count} engine sources follow the rules")
