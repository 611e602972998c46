//! flexcal firmware library (placeholder until the firmware issue).
#![no_std]
