# Writes OUTPUT from common/build_info.cc.in with EXCITE_VERSION and the commit
# (cmake -DSOURCE_DIR=... -DOUTPUT=... -DEXCITE_VERSION=... -P build_info.cmake).
# Runs at every build; OUTPUT changes only when the commit does, so nothing
# recompiles otherwise.
if(DEFINED ENV{EXCITE_COMMIT} AND NOT "$ENV{EXCITE_COMMIT}" STREQUAL "")
  set(EXCITE_COMMIT "$ENV{EXCITE_COMMIT}")
else()
  set(EXCITE_COMMIT unknown)
  find_package(Git QUIET)
  if(GIT_FOUND)
    execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --short=12 HEAD
                    WORKING_DIRECTORY ${SOURCE_DIR} OUTPUT_VARIABLE head
                    RESULT_VARIABLE head_failed OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(NOT head_failed)
      set(EXCITE_COMMIT ${head})
      execute_process(COMMAND ${GIT_EXECUTABLE} diff --quiet HEAD --
                      WORKING_DIRECTORY ${SOURCE_DIR} RESULT_VARIABLE dirty ERROR_QUIET)
      if(dirty)
        string(APPEND EXCITE_COMMIT -dirty)
      endif()
    endif()
  endif()
endif()
configure_file(${SOURCE_DIR}/common/build_info.cc.in ${OUTPUT}.tmp @ONLY)
file(COPY_FILE ${OUTPUT}.tmp ${OUTPUT} ONLY_IF_DIFFERENT)
file(REMOVE ${OUTPUT}.tmp)
