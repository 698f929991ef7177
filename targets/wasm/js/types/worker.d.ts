import type { Indices, Scene, SceneOptions } from './core.js';
/**
 * Scene.build on a Web Worker (made from a Blob URL; worker_threads in Node): the scene, and its
 * .kdt bytes — in a SharedArrayBuffer when the page is cross-origin isolated, to share with query
 * workers (Scene.fromBytes in each), else in an ArrayBuffer.
 */
export declare function buildInWorker(positions: Float32Array, indices?: Indices | null, options?: SceneOptions): Promise<{ scene: Scene; bytes: Uint8Array }>;
